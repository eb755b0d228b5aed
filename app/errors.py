"""The old spelling of core.errors."""
from core.errors import UserError  # noqa: F401

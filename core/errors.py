"""Errors a user can cause. The CLI prints them as one line and exits non-zero."""


class UserError(Exception):
    """A mistake in input (file, option, path, environment) that the user can fix."""

    exit_code = 2

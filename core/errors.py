"""Errors a user can cause. The CLI prints them as one line and exits non-zero."""


class UserError(Exception):
    """A mistake in input (file, option, path, environment) that the user can fix."""

    exit_code = 2


class DeviceError(UserError):
    """A GPU device failed mid-frame (lost, out of memory): the frame is not made, and the
    renderer goes back to the CPU backend for the next one."""

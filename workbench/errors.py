"""Errors the workbench reports to a user as one line (no traceback)."""


class InputError(ValueError):
    """Bad input: a file, field or parameter, named in the message, is wrong."""

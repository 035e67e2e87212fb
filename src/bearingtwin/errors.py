"""The one exception type the project raises for bad input.

Every user-facing mistake (a missing file, an impossible parameter, an unknown
config value) is raised as :class:`BearingTwinError` with a message that names
the field or file at fault. The command-line entry points catch it, print the
message and exit non-zero, so a user never sees a traceback for their own typo.
"""


class BearingTwinError(ValueError):
    """Bad input: the message names the offending field, value or file."""

"""Exception classes for errors a user can fix (the CLI maps them to exit code 2)."""


class FitdfError(Exception):
    """Base class of every error caused by the user's input or options."""


class DataError(FitdfError, ValueError):
    """A dataset or CSV file is malformed; the message names file, row and column."""


class ModelError(FitdfError, ValueError):
    """Unknown model or chain, or impossible parameter values."""


class OptionError(FitdfError, ValueError):
    """An option or combination of options that cannot be honoured."""

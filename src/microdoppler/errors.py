"""Errors that name the file, the field and what was expected."""

from __future__ import annotations


class InputError(ValueError):
    """Bad input: a file or store that breaks its contract.

    The message is one line: ``<source>: <field>: <problem> (expected <expected>)``.
    The command-line interface prints it without a traceback and exits non-zero.

    Parameters
    ----------
    source : str or path-like
        The file, store or option at fault.
    field : str
        The attribute, array, column or key at fault.
    problem : str
        What is wrong with it.
    expected : str, optional
        What was expected.

    Examples
    --------
    >>> from microdoppler.errors import InputError
    >>> err = InputError("flight.zarr", "attrs.prf_hz", "is -1", "a number > 0 [Hz]")
    >>> str(err)
    'flight.zarr: attrs.prf_hz: is -1 (expected a number > 0 [Hz])'
    >>> isinstance(err, ValueError), err.field
    (True, 'attrs.prf_hz')
    """

    def __init__(self, source, field: str, problem: str, expected: str | None = None):
        self.source = str(source)
        self.field = field
        self.problem = problem
        self.expected = expected
        msg = f"{self.source}: {field}: {problem}"
        if expected:
            msg += f" (expected {expected})"
        super().__init__(msg)


class ConfigError(InputError):
    """A configuration value is invalid."""

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


def unknown_key(source, section: str, key, known, note: str = "") -> ConfigError:
    """The one-line error of an unknown key ``key`` of section ``section`` (a dotted
    path such as ``datasets.calibration``; empty: the top level), with ``note`` (why
    the key is gone, say) after the keys it accepts.

    Examples
    --------
    >>> print(unknown_key("my.yaml", "classifier", "epoch", ["max_epochs", "batch_size"]))
    my.yaml: classifier.epoch: unknown key in section classifier (expected one of: batch_size, max_epochs)
    """
    where = f"{section}.{key}" if section else str(key)
    place = f"section {section}" if section else "the top level"
    expected = f"one of: {', '.join(sorted(map(str, known)))}" + (f"; {note}" if note else "")
    return ConfigError(source, where, f"unknown key in {place}", expected)


def check_config_keys(config: dict, schema: dict, source="config") -> None:
    """Reject a configuration key that its schema does not define.

    Every mapping of ``config`` whose schema lists ``properties`` may hold only those
    keys: a typo such as ``classifier.lerning_rate`` is an error instead of a silently
    ignored setting. A mapping whose schema gives ``additionalProperties`` a schema of
    its own, or sets it to ``true``, is left to that (the pipeline's schema, generated
    by :mod:`microdoppler.settings`, has none).

    Parameters
    ----------
    config : dict
        The configuration (the merged config files).
    schema : dict
        Its JSON schema (``workflow/schemas/config.schema.yaml``).
    source : str
        What the error names as the file.

    Raises
    ------
    ConfigError
        For the first unknown key, in one line naming the key, its section and the
        keys the section accepts.

    Examples
    --------
    >>> schema = {"properties": {"classifier": {"properties": {"learning_rate": {}}}}}
    >>> check_config_keys({"classifier": {"learning_rate": 0.01}}, schema)
    >>> try:
    ...     check_config_keys({"classifier": {"lerning_rate": 0.01}}, schema)
    ... except ConfigError as exc:
    ...     print(exc)
    config: classifier.lerning_rate: unknown key in section classifier (expected one of: learning_rate)
    """

    def walk(cfg, sch, path):
        props = sch.get("properties")
        open_ = sch.get("additionalProperties")
        if not isinstance(cfg, dict) or props is None or isinstance(open_, dict) or open_ is True:
            return
        for key, value in cfg.items():
            where = f"{path}.{key}" if path else str(key)
            if key not in props:
                raise unknown_key(source, path, key, props)
            walk(value, props[key], where)

    walk(config, schema, "")

"""The bounds of every input: one table that the CLI and REST both apply (issue 29).

A plan file read by ``rcb optimize`` and a plan posted to ``POST /plans`` hold the same structure;
a number, a name, a list or a file the CLI reads is bounded as REST bounds it. The REST schemas
(:mod:`api.rest.schemas`), the domain readers (:mod:`models.fields`, :mod:`models.tool`,
:mod:`supervisor.inputs`), ``rcb fit`` and ``rcb collect``'s configuration import these values;
none restates them. :data:`BOUNDS` lists them with what each bounds, for the docs and for the
tests that send each one past its bound to both surfaces (``tests/models/test_bounds.py``).

These are bounds on the input, not physics: far above any machining value and far below where
the physics' squares and powers overflow a float.
"""

from __future__ import annotations

from dataclasses import dataclass

from models.errors import InputError

#: The largest magnitude of any number in any input, in the field's unit (1e12 N, 1e12 mm³).
LARGEST = 1e12
#: The least value of a positive input (a limit, a bound, K, a diameter, a volume): no
#: subnormal like 5e-324, whose ratios and powers in the physics overflow a float.
SMALLEST_POSITIVE = 1e-12
#: The least measured value or uncertainty in a part report or a collector's signal: a reading
#: is this far above 0 that the band law's ratios of it stay finite.
SMALLEST_MEASURED = 1e-9
#: The largest magnitude of a power-law exponent or its standard error: machining exponents lie
#: within ±10 (Taylor's 1/n of a ceramic edge near 8); beyond ±100 ``x^e`` overflows a float.
LARGEST_EXPONENT = 100.0
#: The largest whole number an input may hold (a setpoint version, a plan id): what a 32-bit
#: integer column stores.
LARGEST_WHOLE = 2**31 - 1
#: The most flutes of a milling tool.
MAX_FLUTES = 1000
#: The most operations of a plan, and of one part report (a report lists a plan's operations).
MAX_OPERATIONS = 100
#: The most inline tools of a plan.
MAX_TOOLS = 100
#: The most sensor calibrations of a plan's machine.
MAX_CALIBRATIONS = 100
#: The most keys of a table of free-form settings in a REST body (``constant_load``): checked
#: before the domain reader, which refuses an unknown key (in a plan file too).
MAX_TABLE_KEYS = 100
#: The most parts an edge may be reported to have made.
MAX_EDGE_PARTS = 1_000_000
#: The most characters of an identifier (a serial, a name) once normalised: its column's width.
MAX_IDENTITY = 200
#: The most characters of a free text (a description, a source, a reference).
MAX_TEXT = 2000
#: The most bytes of a REST request body, and of a TOML file the CLI reads (a plan file, a
#: domain file, ``collector.toml``): a plan file is a request body's structure.
MAX_DOCUMENT_BYTES = 1024 * 1024
#: The most bytes of a file of learned models (``rcb models export`` writes, ``import`` reads):
#: a tool's models on a plant's machines, ten plans each, about 2.6 kB a model (a plant of 12
#: machines wrote 1.25 MB for one insert); a few plants' exports held in one.
MAX_MODELS_BYTES = 64 * 1024 * 1024
#: The most bytes of ``rcb fit``'s CSV file.
MAX_CSV_BYTES = 16 * 1024 * 1024
#: The most data rows of ``rcb fit``'s CSV file (after the header line).
MAX_CSV_ROWS = 100_000


@dataclass(frozen=True)
class Bound:
    """One bound, as the docs and the tests list it.

    Parameters
    ----------
    name : str
        The constant's name in this module.
    value : float
        Its value.
    what : str
        What it bounds, in words.
    """

    name: str
    value: float
    what: str


#: Every bound of this module, with what it bounds.
BOUNDS: tuple[Bound, ...] = (
    Bound("LARGEST", LARGEST, "magnitude of any number, in its unit"),
    Bound(
        "SMALLEST_POSITIVE", SMALLEST_POSITIVE, "least positive input (limits, bounds, K, volumes)"
    ),
    Bound("SMALLEST_MEASURED", SMALLEST_MEASURED, "least measured value or uncertainty"),
    Bound("LARGEST_EXPONENT", LARGEST_EXPONENT, "magnitude of an exponent or its standard error"),
    Bound("LARGEST_WHOLE", LARGEST_WHOLE, "a whole number (setpoint version)"),
    Bound("MAX_FLUTES", MAX_FLUTES, "flutes of a milling tool"),
    Bound("MAX_OPERATIONS", MAX_OPERATIONS, "operations of a plan or a part report"),
    Bound("MAX_TOOLS", MAX_TOOLS, "inline tools of a plan"),
    Bound("MAX_CALIBRATIONS", MAX_CALIBRATIONS, "calibrations of a machine"),
    Bound("MAX_TABLE_KEYS", MAX_TABLE_KEYS, "keys of a table of settings (constant_load)"),
    Bound("MAX_EDGE_PARTS", MAX_EDGE_PARTS, "parts an edge made (edge_parts)"),
    Bound("MAX_IDENTITY", MAX_IDENTITY, "characters of a serial or a name"),
    Bound("MAX_TEXT", MAX_TEXT, "characters of a description, source or reference"),
    Bound("MAX_DOCUMENT_BYTES", MAX_DOCUMENT_BYTES, "bytes of a REST body or a TOML file"),
    Bound("MAX_MODELS_BYTES", MAX_MODELS_BYTES, "bytes of a file of learned models"),
    Bound("MAX_CSV_BYTES", MAX_CSV_BYTES, "bytes of rcb fit's CSV file"),
    Bound("MAX_CSV_ROWS", MAX_CSV_ROWS, "rows of rcb fit's CSV file"),
)


def check_count(count: int, most: int, path: str, what: str) -> None:
    """Refuse more than ``most`` entries; the error names ``path`` and the count.

    Raises
    ------
    InputError
        ``operations = 10000: at most 100 operations``: the field, the count and the bound.
    """
    if count > most:
        raise InputError(path, count, f"at most {most} {what}")

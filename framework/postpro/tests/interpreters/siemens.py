"""Reads a Siemens 840D program with the PyPI package nc-gcode-interpreter; prints CSV for
tests/interpreters.rs.

Usage: python siemens.py PROGRAM.mpf AXES   (AXES: the machine's axis letters, e.g. XYZAC)

The interpreter turns the program into a table with one row per line of the program: the modal
G groups (gg01_motion: G0/G1, gg15_feed_type: G93/G94...), the axis values (the interpreter's own
state, carried forward from block to block), F, M and the comment. It is run twice: with the
values carried forward (the positions) and without (which axes each line programs).

Output: a header `row,motion,feed_type,f,programmed,<axes...>`, then one line per row of the
table; `programmed` lists the axes the line writes; an empty field is none. A parse error goes
to standard error with exit code 1.
"""

import sys

from nc_gcode_interpreter import nc_to_dataframe

# The interpreter's default axes; others are passed as extra axes.
DEFAULT_AXES = ("X", "Y", "Z", "A", "B", "C")


def text(value):
    return "" if value is None else str(value)


def main():
    path, axes = sys.argv[1], list(sys.argv[2])
    with open(path, encoding="utf-8") as f:
        program = f.read()
    extra = [a for a in axes if a not in DEFAULT_AXES] or None
    try:
        filled, _ = nc_to_dataframe(program, extra_axes=extra)
        bare, _ = nc_to_dataframe(program, extra_axes=extra, disable_forward_fill=True)
    except Exception as e:  # the interpreter's parse and evaluation errors are ValueErrors
        print(f"nc-gcode-interpreter: {e}", file=sys.stderr)
        sys.exit(1)
    if filled.height != bare.height:
        print("nc-gcode-interpreter: the two readings differ in length", file=sys.stderr)
        sys.exit(1)
    columns = set(filled.columns)
    print(",".join(["row", "motion", "feed_type", "f", "programmed"] + axes))
    for i in range(filled.height):
        row = filled.row(i, named=True)
        bare_row = bare.row(i, named=True)
        programmed = "".join(a for a in axes if a in columns and bare_row[a] is not None)
        fields = [
            str(i),
            text(row.get("gg01_motion")),
            text(row.get("gg15_feed_type")),
            text(bare_row.get("F")),
            programmed,
        ] + [repr(row[a]) if a in columns and row[a] is not None else "" for a in axes]
        print(",".join(fields))


if __name__ == "__main__":
    main()

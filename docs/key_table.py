"""README's input table, written from the core's key table (fortran/src/config/tmafm_keys.f90,
read by the installed package as tmafm._namelist.KEYS).

    python docs/key_table.py           # print the table
    python docs/key_table.py --write   # replace the table in README.md (between its markers)

tests/test_tables.py checks that README's table is this one, key by key.
"""

import sys
from pathlib import Path

from tmafm._namelist import KEYS

README = Path(__file__).resolve().parents[1] / "README.md"
BEGIN = ("<!-- the key table: written by `python docs/key_table.py --write` from the core's "
         "fortran/src/config/tmafm_keys.f90; tests/test_tables.py checks it -->")
END = "<!-- end of the key table -->"
HEADER = "| group | key | default | unit | range | meaning |\n|---|---|---|---|---|---|"


def cell(text: str) -> str:
    """Text for a Markdown table cell (a | would end the cell)."""
    return text.replace("|", "\\|")


def markdown(keys=KEYS) -> str:
    """The table, one row per key; a group is named on its first row."""
    rows, group = [HEADER], None
    for key in keys:
        shown = f"`&{key.group}`" if key.group != group else ""
        group = key.group
        rows.append(f"| {shown} | `{key.name}` | `{cell(key.default)}` | {cell(key.unit)} | "
                    f"{cell(key.range)} | {cell(key.meaning)} |")
    return "\n".join(rows)


def block(keys=KEYS) -> str:
    """The table between its markers, as README holds it."""
    return f"{BEGIN}\n{markdown(keys)}\n{END}"


def readme_block(text: str) -> str:
    """The marked table in README's text."""
    start, end = text.index(BEGIN), text.index(END) + len(END)
    return text[start:end]


def main(argv) -> None:
    if argv == ["--write"]:
        text = README.read_text()
        README.write_text(text.replace(readme_block(text), block()))
    elif not argv:
        print(markdown())
    else:
        raise SystemExit(__doc__)


if __name__ == "__main__":
    main(sys.argv[1:])

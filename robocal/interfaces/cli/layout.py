"""Fitting what the command line prints to the width of the line, so that a result reads in
an 80-column log: a note wrapped between words, a table laid out so that no number is cut
(rich, left to itself, cuts a cell of a table too wide for the line to "-424…"), a title
wrapped.  The result console (:mod:`robocal.interfaces.cli.rendering`) passes everything it
prints through :func:`fitted`."""
import copy
import dataclasses
import textwrap

from rich import box
from rich.console import Group
from rich.measure import Measurement
from rich.table import Table
from rich.text import Text


def fitted(renderable, console):
    """``renderable`` fitted to the ``console``'s width: a note (a string, or a Text of one
    style) wrapped, a table laid out by :func:`_fitted_table`; anything else as it is."""
    width = console.width
    if isinstance(renderable, str) and len(renderable) > width:
        return wrapped(renderable, width)
    if isinstance(renderable, Text) and not renderable.spans and len(renderable.plain) > width:
        return Text(wrapped(renderable.plain, width), style=renderable.style)
    if isinstance(renderable, Table):
        return _fitted_table(renderable, console)
    return renderable


def _fitted_table(table, console):
    """``table`` within the console's width with every number whole: rich, left to itself,
    cuts the cells of a table too wide for the line to "-424…".  Each column gets at least its
    longest word (a number is one word; headers and labels wrap between words); when that is
    too wide with the table's borders, the table is drawn without them (one space between
    columns); when even that is too wide, its columns are shown in several tables, each with
    the first column (the row's label).  A word wider than the line itself is folded, never
    cut.  The title is wrapped between words."""
    width = console.width
    options = console.options.update_width(10 ** 6)  # a cell's widths, unclamped
    sizes = [[Measurement.get(console, options, cell)
              for cell in ([column.header] if table.show_header else []) + list(column._cells)] or
             [Measurement(1, 1)] for column in table.columns]
    least = [max(m.minimum for m in cells) for cells in sizes]
    most = [max(m.maximum for m in cells) for cells in sizes]
    if sum(most) + table._extra_width + sum(table._get_padding_width(k) for k in range(len(most))) > width:
        every = range(len(table.columns))
        whole = _part(table, every, least, most, width) or _part(table, every, least, most, width, box.SIMPLE_HEAD)
        parts = [whole]
        if whole is None:  # one table per group of columns that fits, each led by the label
            parts, group = [], [0]
            for k in range(1, len(table.columns)):
                if len(group) > 1 and _part(table, group + [k], least, most, width, box.SIMPLE_HEAD) is None:
                    parts.append(_part(table, group, least, most, width, box.SIMPLE_HEAD, fold=True))
                    group = [0]
                group.append(k)
            parts.append(_part(table, group, least, most, width, box.SIMPLE_HEAD, fold=True))
            if len(parts) == 1:  # no part fits: the table as it is, its widest words folded
                parts = [_part(table, every, least, most, width, fold=True)]
            for k, part in enumerate(parts[1:], start=2):
                part.title = f"({k}/{len(parts)}) {table.title}" if isinstance(table.title, str) else None
        parts = [_titled(part, width) for part in parts]
        return parts[0] if len(parts) == 1 else Group(*parts)
    return _titled(table, width)


def _part(table, columns, least, most, width, style=None, fold=False):
    """A copy of ``table`` with only the ``columns`` (indices), drawn with the box ``style``
    (None: the table's own; a style here: no edge and no padding), each column as wide as
    its ``least`` word and more up to its ``most`` while the total fits ``width``; None when
    even the least does not fit (unless ``fold``: then what is still too wide folds)."""
    part = copy.copy(table)
    part.columns = [dataclasses.replace(table.columns[k], _index=n) for n, k in enumerate(columns)]
    if style is not None:
        part.box, part.show_edge, part.padding, part.pad_edge = style, False, (0, 0, 0, 0), False
    widths = [least[k] for k in columns]
    spare = width - part._extra_width - sum(w + part._get_padding_width(n) for n, w in enumerate(widths))
    if spare < 0 and not fold:
        return None
    if spare < 0:  # a word wider than the line: its column folds, the others whole if they can be
        wide = widths.index(max(widths))
        others = sum(most[k] for n, k in enumerate(columns) if n != wide) - (sum(widths) - widths[wide])
        if widths[wide] + spare - others >= 10:
            widths = [widths[n] + spare - others if n == wide else most[k] for n, k in enumerate(columns)]
            spare = 0
    while spare < 0 and max(widths) > 1:
        n = widths.index(max(widths))
        narrower = min(-spare, widths[n] - 1)
        widths[n], spare = widths[n] - narrower, spare + narrower
    for n in sorted(range(len(columns)), key=lambda n: most[columns[n]] - widths[n]):
        grow = min(spare, most[columns[n]] - widths[n])
        part.columns[n].width, part.columns[n].overflow = widths[n] + grow, "fold"
        spare -= grow
    return part


def _titled(table, width):
    """``table`` with its title wrapped at ``width`` between words (the console prints a
    title unwrapped)."""
    if isinstance(table.title, str) and len(table.title) > width:
        table = copy.copy(table)
        table.title = "\n".join(textwrap.wrap(table.title, width=width, break_long_words=False,
                                              break_on_hyphens=False))
    return table


def wrapped(text, width):
    """``text`` in lines of at most ``width`` characters, broken between words only (a long
    file name stays whole), the later lines indented two spaces more than the first."""
    lead = text[:len(text) - len(text.lstrip(" "))]
    return "\n".join(textwrap.wrap(text.lstrip(" "), width=width, initial_indent=lead, subsequent_indent=lead + "  ",
                                   break_long_words=False, break_on_hyphens=False))

"""volkit in Python: open, save, generate, index, compare and render volumes
as numpy arrays, through the same library the volkit command-line tools use
(the same readers, writers, renderer, option names and one-line messages).

Axis order: every shape, spacing, origin and direction is in numpy's order
(z, y, x), as napari and scikit-image expect; ``dims`` of ``generate`` and
``render``'s points and directions (``eye``, ``look_at``, ``up``,
``light``) too. Text options that are the command line's own
(``raw_dims="X,Y,Z"`` of ``open``, ``size="WxH"`` of ``render``) and scene
files keep the command line's order.

Arrays: any numpy memory layout (C or Fortran order, transposed, strided or
reversed views) is read in its logical (z, y, x) order, as a C-order copy
of the same data would be.

Errors: bad options raise ``ValueError``, file problems ``OSError`` (a missing
input ``FileNotFoundError``), with the tools' one-line messages; Ctrl-C during
a long call raises ``KeyboardInterrupt`` (the work stops at the next tile,
pass or slice). Long calls release the GIL.
"""

from ._volkit import (  # noqa: F401
    Index,
    Volume,
    __version__,
    from_array,
    generate,
    index,
    open,
    preprocess,
    psnr,
    save,
)
from ._volkit import render as _render
from ._volkit import render_options as _render_options


def render(volume=None, *, progress=None, **options):
    # A Python function around the extension's, for the docstring below.
    return _render(volume, progress=progress, **options)


def _options_doc():
    """The option list of render's docstring, from vol-render's own
    definition of its options (what the keywords are parsed by)."""
    import textwrap

    lines = ["", "Options (vol-render's flags as keywords, from its definition):"]
    heading = None
    for name, value, text, group in _render_options():
        if group != heading and group:
            lines += ["", f"{group}:"]
        heading = group
        lines.append(f"    {name}={value}" if value else f"    {name}=True")
        lines += textwrap.wrap(text, 76, initial_indent=" " * 8, subsequent_indent=" " * 8)
    return "\n".join(lines)


render.__doc__ = (_render.__doc__ or "") + "\n" + _options_doc()

__all__ = [
    "Index",
    "Volume",
    "from_array",
    "generate",
    "index",
    "open",
    "preprocess",
    "psnr",
    "render",
    "save",
]

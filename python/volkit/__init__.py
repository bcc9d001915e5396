"""volkit in Python: open, save, generate, index, compare and render volumes
as numpy arrays, through the same library the volkit command-line tools use
(the same readers, writers, renderer, option names and one-line messages).

Axis order: every shape, spacing, origin and direction is in numpy's order
(z, y, x), as napari and scikit-image expect; ``dims`` of ``generate`` too.
Text options that are the command line's own (``raw_dims="X,Y,Z"`` of
``open``, ``size="WxH"`` of ``render``) keep the command line's order.

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
    render,
    save,
)

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

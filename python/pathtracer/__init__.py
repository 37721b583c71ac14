"""pathtracer: the renderer's library from Python.

Scenes load from any format the command line reads; renders return ``numpy.float32`` arrays
of shape (height, width, 3), linear RGB, bit-identical to the command line's with the same
options. Example::

    import pathtracer as pt

    scene = pt.load("CBbunny.dae")
    image = pt.render(scene, spp=64, max_depth=8, seed=1)
    pt.write_image("bunny.exr", image)
"""

import os
from typing import Union

import numpy as np

from . import _core
from ._core import (
    Camera,
    Error,
    Film,
    OptionError,
    Scene,
    __version__,
    aux,
    denoise,
    load,
    option_table,
    parse_args,
    read_image,
    render,
    render_film,
    resolve_options,
)

__all__ = [
    "Camera",
    "Error",
    "Film",
    "OptionError",
    "Scene",
    "__version__",
    "aux",
    "denoise",
    "load",
    "option_table",
    "parse_args",
    "read_image",
    "render",
    "render_film",
    "resolve_options",
    "write_image",
]


def write_image(path: Union[str, "os.PathLike[str]"], image: "np.ndarray") -> None:
    """Writes an array (height, width, 3) of linear RGB to `path`: `.exr` as linear float,
    `.png` as 8-bit sRGB; atomically. Any float dtype is converted to float32; non-finite
    values raise `ValueError`."""
    _core.write_image(path, np.ascontiguousarray(image, dtype=np.float32))

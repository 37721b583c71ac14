"""pathtracer: the renderer's library from Python.

Scenes load from any format the command line reads; renders return ``numpy.float32`` arrays
of shape (height, width, 3), linear RGB, bit-identical to the command line's with the same
options. Example::

    import pathtracer as pt

    scene = pt.load("CBbunny.dae")
    image = pt.render(scene, spp=64, max_depth=8, seed=1)
    pt.write_image("bunny.exr", image)
"""

from ._core import (
    Camera,
    Error,
    Film,
    Scene,
    __version__,
    aux,
    load,
    read_image,
    render,
    render_film,
    write_image,
)

__all__ = [
    "Camera",
    "Error",
    "Film",
    "Scene",
    "__version__",
    "aux",
    "load",
    "read_image",
    "render",
    "render_film",
    "write_image",
]

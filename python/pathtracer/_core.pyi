"""Type stubs of the compiled module `pathtracer._core` (see its docstrings)."""

import os
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
from typing_extensions import TypeAlias

_Path: TypeAlias = str | os.PathLike[str]
_Vec3: TypeAlias = Sequence[float]
_Image: TypeAlias = npt.NDArray[np.float32]

__version__: str

class Error(Exception):
    """A scene, image or film that cannot be read or written, or invalid options; the message
    is the command line's (file and line where there is one)."""

class OptionError(Error, ValueError):
    """A render option out of its range or of the wrong type; the message names the option
    and its allowed values."""

class Camera:
    """The camera of a scene: position, target, up, field of view, lens."""

    def __init__(
        self,
        position: _Vec3,
        target: _Vec3,
        up: _Vec3 = (0.0, 1.0, 0.0),
        fov: float | None = None,
        lens_radius: float | None = None,
        focal_distance: float | None = None,
    ) -> None: ...
    position: _Vec3
    target: _Vec3
    up: _Vec3
    fov: float | None
    """Vertical field of view in degrees over the image height (``--fov``); None keeps the
    scene's."""
    lens_radius: float
    focal_distance: float
    def field_of_view(self, height: int = 360) -> float:
        """The vertical field of view in degrees over an image `height` pixels high."""

class Scene:
    """A loaded scene."""

    @property
    def name(self) -> str: ...
    @property
    def summary(self) -> str:
        """What ``pathtracer --info`` prints."""
    @property
    def warnings(self) -> list[str]: ...
    @property
    def notes(self) -> list[str]: ...
    @property
    def files(self) -> list[os.PathLike[str]]:
        """The files the scene was read from."""
    camera: Camera
    """A copy of the camera: change it and assign it back."""

class Film:
    """The exact sums of a render: merge, develop, save, load; pickles as its bytes."""

    def __init__(
        self,
        width: int = 480,
        height: int = 360,
        cell: tuple[int, int, int, int] | None = None,
        first: int = 0,
    ) -> None: ...
    @property
    def frame(self) -> tuple[int, int]: ...
    @property
    def cell(self) -> tuple[int, int, int, int]: ...
    @property
    def first(self) -> int: ...
    @property
    def samples(self) -> int: ...
    def counts(self) -> npt.NDArray[np.uint32]: ...
    def develop(self) -> _Image: ...
    def features(self) -> dict[str, _Image] | None:
        """Mean albedo and normal over its samples (rendered with `features` or `denoise`)."""
    def merge(self, other: Film) -> None: ...
    def save(self, path: _Path) -> None: ...
    @staticmethod
    def load(path: _Path) -> Film: ...
    def to_bytes(self) -> bytes: ...
    @staticmethod
    def from_bytes(data: bytes) -> Film: ...

def load(
    path: _Path | None = None,
    env: _Path | None = None,
    env_sampling: str | None = None,
    camera_file: _Path | None = None,
    defines: dict[str, str] | None = None,
    no_default_light: bool | None = None,
) -> Scene:
    """Loads a scene (.dae, .obj, .ply, .gltf, .glb, .pbrt, Mitsuba .xml; None: the built-in
    Cornell box); `defines` sets a Mitsuba scene's `$name` parameters (`-D name=value`);
    `no_default_light=True` leaves a model file without lights unlit (otherwise the built-in
    studio light lights it, as `Scene.notes` says)."""

# Render options (keyword arguments of render, render_film and aux) are those of
# option_table() whose `python` is 'render' or 'camera', under their names: spp, max_depth,
# width, height, lookat, ...; `pathtracer --help` gives their flags and defaults.

def render(scene: Scene, **options: object) -> _Image:
    """Renders and returns a float32 array (height, width, 3), linear RGB (denoised with
    `denoise=True`)."""

def render_film(scene: Scene, film: Film | None = None, **options: object) -> Film:
    """Renders into `film` (continuing it) or a new film, and returns it."""

def aux(scene: Scene, **options: object) -> dict[str, _Image]:
    """Albedo, normal and depth images over the render's camera samples."""

def denoise(image: _Image, albedo: _Image | None = None, normal: _Image | None = None) -> _Image:
    """Denoises a linear HDR image with Open Image Denoise on its features (`pip install
    pyoidn`); the result is finite."""

def write_image(path: _Path, image: _Image) -> None: ...
def read_image(path: _Path) -> _Image: ...
def resolve_options(scene: Scene | None = None, **options: object) -> list[tuple[str, str]]:
    """The options a render with these keywords would use, as `pathtracer --dry-run` prints
    them ('none' where unset), without rendering."""

def option_table() -> list[dict[str, object]]:
    """The option vocabulary: name, flag, values, python, json, default, unset, allowed, kind,
    help of every option."""

def parse_args(argv: Sequence[str]) -> dict[str, object]:
    """Render arguments parsed by the command line's parser: scene, output, env, camera_file,
    env_sampling, no_default_light and options (the options given, as render keywords)."""

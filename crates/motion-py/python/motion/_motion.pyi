"""Type stubs of the compiled module (see the ``motion`` package docstring)."""

from os import PathLike
from typing import Any, Literal, Optional, Sequence, Union, overload

import numpy as np
import numpy.typing as npt

ArrayLike = npt.ArrayLike
F64 = npt.NDArray[np.float64]
Path = Union[str, PathLike]

__version__: str

def npss(
    gt: ArrayLike,
    pred: ArrayLike,
    variant: Literal["paper", "reference"] = "paper",
    input_space: Literal["raw", "expmap"] = "raw",
) -> float:
    """NPSS of ``pred`` against ``gt`` (both ``N x T x D``).

    >>> motion.npss(gt, gt)
    0.0
    """

def npss_windows(
    gt: ArrayLike,
    pred: ArrayLike,
    variant: Literal["paper", "reference"] = "paper",
    input_space: Literal["raw", "expmap"] = "raw",
) -> dict[str, float]:
    """NPSS per window of the protocol (25 Hz frames), ``{label: value}``."""

def euler_error(gt: ArrayLike, pred: ArrayLike) -> F64:
    """The H3.6M protocol's Euler-angle error per frame of exp-map ``N x T x D`` inputs."""

@overload
def apd(samples: ArrayLike) -> float: ...
@overload
def apd(samples: ArrayLike, per_sequence: Literal[True]) -> tuple[float, F64]: ...
def apd(samples: ArrayLike, per_sequence: bool = False) -> Any:
    """APD of ``S x F`` samples, or the mean over ``N x S x ...`` forecasts."""

class NdmsDatabase:
    """Motion words of reference positions (``T x 32 x 3``, H3.6M, y up) with an exact index."""

    word_len: int
    def __init__(
        self,
        positions: Union[ArrayLike, Sequence[ArrayLike]],
        word_len: int = 8,
        method: Literal["pose-bound", "pca-kd-tree", "brute-force"] = "pose-bound",
    ) -> None: ...
    def __len__(self) -> int: ...
    def score(
        self,
        forecasts: Union[ArrayLike, Sequence[ArrayLike]],
        seeds: Optional[Union[ArrayLike, Sequence[ArrayLike]]] = None,
    ) -> dict[str, Any]:
        """``{"mean", "per_word", "bins", "first_word_end"}`` of the forecasts' NDMS."""

def posture(
    predictions: ArrayLike,
    action: str,
    seeds: Optional[ArrayLike] = None,
    data: Optional[Path] = None,
) -> dict[str, Any]:
    """Posture realism of H3.6M predictions (``T x 99``, ``N x T x 99`` or ``N x S x T x 99`` exp-map frames at
    25 Hz) of ``action`` per window after their seeds (``N x T_s x 99``), against the action's real takes,
    beside the real-vs-real value: the ``posture`` of ``motion-cli score --metric posture --json``."""
    ...

def evaluate(
    model: Optional["Model"] = None,
    data: Optional[Path] = None,
    actions: Union[str, list[str], None] = None,
    horizon: int = 100,
    samples: Optional[int] = None,
    rng_seed: int = 0,
    classifier: Union[bool, Path, None] = None,
    windows: Union[str, int, None] = None,
    any_action: bool = False,
    protocol: str = "h36m",
    stride: Optional[int] = None,
    input_frames: Optional[int] = None,
    ltd_sampler: bool = False,
    joints: str = "all-32",
) -> dict[str, Any]:
    """The H3.6M protocol: the report of ``motion-cli eval --json`` as a dict.

    ``windows="validation"`` runs the S5 windows disjoint from the test windows
    (``motion-cli eval --windows validation``). ``protocol="mpjpe"`` runs the 3-D
    joint-position protocol (``motion-cli eval --protocol mpjpe``): ``windows`` 256
    (default), 8 or ``"all"`` with ``stride``. ``protocol="stochastic"``: APD, ADE, FDE,
    MMADE, MMFDE in the project's variant of DLow's protocol (``samples`` default 50)."""

def mpjpe(gt: ArrayLike, pred: ArrayLike, input_space: str = "expmap", joints: str = "all-32") -> F64:
    """MPJPE (mm) per predicted frame, the mean over sequences (LTD, HRI, siMLPe)."""

def sample_set_metrics(
    samples: ArrayLike, gt: ArrayLike, last_observed: ArrayLike, threshold: float = 0.5
) -> dict[str, Any]:
    """APD, ADE, FDE, MMADE, MMFDE of ``N x K x T x D`` samples (DLow, BeLFusion)."""

def read_bvh(path: Path) -> dict[str, Any]:
    """``{"channels", "fps", "joints", "parents", "offsets", "expmap"}`` of a BVH file."""

def write_bvh(path: Path, frames: ArrayLike, fps: float = 25.0) -> None:
    """Writes exp-map frames (``T x 99`` or ``T x 117``) as BVH."""

def read_expmap(path: Path) -> F64:
    """Exp-map frames of ``.txt``, ``.txt.gz`` or ``.npy``."""

def expmap_to_positions(frames: ArrayLike, fps: float = 25.0) -> F64:
    """World joint positions, ``T x J x 3`` millimetres, of exp-map frames at ``fps``."""

def set_threads(threads: int) -> None:
    """Threads for the metrics and generators (once, before the first computation)."""

def data_address(array: ArrayLike) -> int:
    """Address of the data the bindings read (``array.ctypes.data`` when read in place)."""

class Model:
    """A motion model.

    >>> model = motion.Model.default()
    >>> model.predict("examples/walk_seed.bvh", action="walking", frames=100).shape
    (1, 100, 99)
    """

    actions: list[str]
    fps: float
    seed_frames: int
    frame_dims: int
    @staticmethod
    def load(path: Path) -> "Model": ...
    @staticmethod
    def default() -> "Model": ...
    def info(self) -> dict[str, Any]: ...
    def predict(
        self,
        seed: Union[Path, ArrayLike],
        action: Optional[str] = None,
        frames: int = 100,
        samples: int = 1,
        rng_seed: int = 0,
        input_fps: Optional[float] = None,
        grounding: bool = True,
    ) -> F64: ...
    def generator(self, rng_seed: int = 0) -> "Generator": ...

class Generator:
    """Frame-by-frame generation: ``start(seed, action)`` then ``step()``."""

    def start(self, seed: ArrayLike, action: Optional[str] = None) -> None: ...
    def step(self) -> F64: ...
    def set_action(self, action: str, crossfade: int = 0) -> None: ...
    def set_control(self, control: list[float]) -> None:
        """``[forward, side, turn]`` for a ``goal-gru`` model (m/s, m/s, rad over the next second)."""

class Character:
    """One engine character: a learned model or a motion-matching database.

    ``start(seed)``, then ``advance(dt)`` at the engine's rate for the root's world position
    (metres) and every joint's local rotation (``joints x 4``, ``x, y, z, w``; joint 0 the
    root's world rotation), steered by ``set_goal``. A database
    (``weights/matching_cmu.safetensors``) plays on its own rig (``joint_names``) and has no
    actions.

    >>> c = motion.Character("weights/matching_cmu.safetensors")
    >>> c.start("examples/walk_seed.bvh")
    >>> c.set_goal((1.2, 0.0))
    >>> root, rotations = c.advance(1 / 60)
    """

    is_database: bool
    joint_names: list[str]
    fps: float
    def __init__(self, weights: Optional[Path] = None, grounding: bool = True) -> None: ...
    def start(self, seed: Path, action: Optional[str] = None, rng_seed: int = 0) -> None: ...
    def set_goal(self, velocity: tuple[float, float], facing: Optional[float] = None) -> None: ...
    def clear_goal(self) -> None: ...
    def set_action(self, action: str, crossfade: int = 0) -> None: ...
    def advance(
        self, dt: float
    ) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]: ...


class Rig:
    """A character's own skeleton driven by a ``Character``'s poses (``motion_core::rig_target``): joint names,
    parents (-1 for the root, parents first), rest local rotations (``n x 4``, ``x, y, z, w``) and translations
    (``n x 3``, metres), +y up, facing +z."""

    def __init__(
        self,
        names: Sequence[str],
        parents: Sequence[int],
        rest_rotations: ArrayLike,
        rest_translations: ArrayLike,
        character: "Character",
        joint_map: Optional[str] = None,
    ) -> None: ...
    @staticmethod
    def from_gltf(path: Union[str, "PathLike[str]"], character: "Character", joint_map: Optional[str] = None) -> "Rig": ...
    def joint_names(self) -> list[str]: ...
    def hips(self) -> int: ...
    def pose(self, character: "Character") -> tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]:
        """The local rotation to write into each joint (``n x 4``) and the hips' local translation (3 floats)."""
        ...

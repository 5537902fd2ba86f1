"""Type stubs of rotorid (the native module ``rotorid._rotorid`` and its
Python additions)."""

from os import PathLike
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

__version__: str

class RotorIdError(ValueError):
    """An input rotorid cannot use, or a computation that failed; the
    message is the command line's one line."""

class Model:
    @staticmethod
    def load(path: str | PathLike[str]) -> Model: ...
    @staticmethod
    def paper() -> Model: ...
    @staticmethod
    def vectors(
    path: str | PathLike[str],
    config: str | PathLike[str] | None = None,
    *,
    speed_min_rpm: float | None = None,
    speed_max_rpm: float | None = None,
    revolutions: int = 8,
    pool: bool = True,
) -> tuple[
    npt.NDArray[np.float64],
    npt.NDArray[np.complex128],
    npt.NDArray[np.float64],
    dict[str, Any],
]: ...
def from_ross(rotor: Any) -> Model: ...
    @property
    def name(self) -> str: ...
    @property
    def label(self) -> str: ...
    @property
    def n_bearings(self) -> int: ...
    @property
    def bearing_nodes(self) -> list[int]: ...
    @property
    def planes(self) -> list[int]: ...
    @property
    def channels(self) -> list[str]: ...
    def simulate(
        self,
        speeds_rpm: npt.NDArray[np.float64],
        *,
        noise: float = 0.0,
        noise_floor: float = 0.0,
        seed: int = 1,
        balance_grade: float | None = None,
    ) -> npt.NDArray[np.complex128]: ...

class Identification:
    @property
    def speed_rpm(self) -> float: ...
    @property
    def k(self) -> npt.NDArray[np.float64]: ...
    @property
    def c(self) -> npt.NDArray[np.float64]: ...
    @property
    def std(self) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]] | None: ...
    def bearings_at(
        self, speeds_rpm: npt.NDArray[np.float64]
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    @property
    def unbalance(self) -> npt.NDArray[np.complex128]: ...
    @property
    def planes(self) -> list[int]: ...
    @property
    def noise(self) -> dict[str, Any] | None: ...
    @property
    def warnings(self) -> list[str]: ...
    def to_dict(self) -> dict[str, Any]: ...
    def ross_toml(self) -> str: ...
    def to_ross(self) -> Any: ...

class Diagnosis:
    @property
    def effect(self) -> str: ...
    @property
    def effects(self) -> list[str]: ...
    @property
    def gain(self) -> float: ...
    @property
    def hypotheses(self) -> list[dict[str, Any]]: ...
    @property
    def observability(self) -> list[dict[str, Any]]: ...
    @property
    def warnings(self) -> list[str]: ...
    def to_dict(self) -> dict[str, Any]: ...

def read_measurements(
    path: str | PathLike[str], model: Model | None = None
) -> tuple[
    npt.NDArray[np.float64],
    npt.NDArray[np.complex128],
    npt.NDArray[np.float64] | None,
]: ...
def identify(
    model: Model,
    speeds_rpm: npt.ArrayLike,
    phasors: npt.ArrayLike,
    std: npt.ArrayLike | None = None,
    *,
    formulation: Literal["physical", "paper"] = "physical",
    estimator: Literal["oe", "rls"] = "oe",
    order: int = 1,
    lam: float = 0.999,
    delta: float = 1e-7,
    f32: bool = False,
    normalise_rows: bool = False,
    steady_margin_rpm: float = 0.0,
    steady_guard: bool = True,
    scaling: bool = True,
    noise_floor: float | None = None,
    runout: Literal["auto", "fit", "none"] = "auto",
    slow_roll_rpm: float | None = None,
    outliers: bool = True,
) -> Identification: ...
def diagnose(
    model: Model,
    speeds_rpm: npt.NDArray[np.float64],
    phasors: npt.NDArray[np.complex128],
    *,
    order: int = 1,
    false_alarm: float = 1e-3,
    noise_floor: float | None = None,
) -> Diagnosis: ...
def campbell(
    model: Model, *, rpm_max: float = 15000.0, rpm_step: float = 250.0, modes: int = 8
) -> dict[str, Any]: ...
def vectors(
    path: str | PathLike[str],
    config: str | PathLike[str] | None = None,
    *,
    speed_min_rpm: float | None = None,
    speed_max_rpm: float | None = None,
    revolutions: int = 8,
    pool: bool = True,
) -> tuple[
    npt.NDArray[np.float64],
    npt.NDArray[np.complex128],
    npt.NDArray[np.float64],
    dict[str, Any],
]: ...
def from_ross(rotor: Any) -> Model: ...
def to_ross(identification: Identification) -> Any: ...

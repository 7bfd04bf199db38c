"""Flowing traffic for a scene: catalog cars arriving at random in each lane, each at its own constant speed,
none catching up with the car ahead of it in its lane while in the scene (faster lanes overtake slower ones,
and near cars hide far ones)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from vehloc.config import SettingError, build_params, check_range
from vehloc.synth.catalog import CATALOG
from vehloc.synth.scene import CarSpec, SceneSpec


@dataclass(frozen=True)
class TrafficLane:
    """One lane: its centre across the road (mm), the heading its cars drive at (deg, +90 along +Y), and their
    speeds (km/h, drawn evenly between the two)."""

    x_mm: float
    heading_deg: float
    speed_kmh: tuple[float, float]

    def __post_init__(self) -> None:
        check_range("speed_kmh", self.speed_kmh[0], 1.0, self.speed_kmh[1])
        check_range("speed_kmh", self.speed_kmh[1], self.speed_kmh[0], 400.0)
        if abs(np.cos(np.radians(self.heading_deg))) > 1e-9:
            raise SettingError("heading_deg", f"{self.heading_deg} is not along the road (+90 or -90)")


@dataclass(frozen=True)
class TrafficSpec:
    """Traffic over `duration_s`: `vehicles_per_minute` shared evenly by the lanes (Poisson arrivals), every car
    crossing the stretch `centre_y_mm` +- `approach_mm`, at least `min_headway_s` behind the car ahead in its lane
    both where it enters and where it leaves, shifted across its lane by up to `lateral_jitter_mm`, of the catalog's
    models (or `model_ids`), a fraction `plates_fraction` of them with licence plates."""

    duration_s: float
    vehicles_per_minute: float
    lanes: tuple[TrafficLane, ...]
    centre_y_mm: float
    approach_mm: float
    min_headway_s: float = 1.5
    lateral_jitter_mm: float = 300.0
    plates_fraction: float = 0.9
    seed: int = 0
    model_ids: tuple[int, ...] | None = None

    def __post_init__(self) -> None:
        check_range("duration_s", self.duration_s, 0.0, 4 * 3600.0, low_open=True)
        check_range("vehicles_per_minute", self.vehicles_per_minute, 0.0, 600.0, low_open=True)
        check_range("approach_mm", self.approach_mm, 0.0, low_open=True)
        check_range("min_headway_s", self.min_headway_s, 0.0)
        check_range("lateral_jitter_mm", self.lateral_jitter_mm, 0.0)
        check_range("plates_fraction", self.plates_fraction, 0.0, 1.0)
        if not self.lanes:
            raise SettingError("lanes", "traffic needs at least one lane")
        known = {model.model_id for model in CATALOG}
        if self.model_ids is not None and (not self.model_ids or not set(self.model_ids) <= known):
            raise SettingError("model_ids", f"expected catalog model ids ({min(known)} to {max(known)}), got "
                                            f"{list(self.model_ids)}")


def traffic_cars(traffic: TrafficSpec, fps: float) -> tuple[CarSpec, ...]:
    """The cars of the traffic, in order of entry, each entering `delay_frames` after the scene's empty frames. The
    models and paints are drawn from a stream of their own: the same seed gives the same arrivals, lanes and speeds
    whatever `model_ids` allows."""
    rng, looks = np.random.default_rng(traffic.seed), np.random.default_rng([traffic.seed, 1])
    models = [m for m in CATALOG if traffic.model_ids is None or m.model_id in traffic.model_ids]
    mean_gap_s = 60.0 * len(traffic.lanes) / traffic.vehicles_per_minute
    stretch_m = 2.0 * traffic.approach_mm / 1000.0
    cars: list[tuple[int, CarSpec]] = []
    for lane in traffic.lanes:
        time_s, ahead_exit_s = rng.exponential(mean_gap_s), -np.inf
        while time_s < traffic.duration_s:
            speed_kmh = float(rng.uniform(*lane.speed_kmh))
            exit_s = time_s + stretch_m / (speed_kmh / 3.6)
            if exit_s < ahead_exit_s + traffic.min_headway_s:  # it would catch up: it enters later
                time_s += ahead_exit_s + traffic.min_headway_s - exit_s
                exit_s = ahead_exit_s + traffic.min_headway_s
            model = models[int(looks.integers(len(models)))]
            x_mm = lane.x_mm + float(rng.uniform(-1.0, 1.0)) * traffic.lateral_jitter_mm
            car = CarSpec(model.model_id, int(looks.integers(len(model.palette))), x_mm,
                          traffic.centre_y_mm, lane.heading_deg, traffic.approach_mm, stops=False,
                          delay_frames=int(round(time_s * fps)), plates=bool(looks.random() < traffic.plates_fraction),
                          speed_kmh=round(speed_kmh, 2))
            cars.append((car.delay_frames, car))
            ahead_exit_s = exit_s
            time_s += max(traffic.min_headway_s, rng.exponential(mean_gap_s))
    cars.sort(key=lambda pair: pair[0])
    return tuple(car for _, car in cars)


def scene_from_config(values: Mapping[str, Any]) -> SceneSpec:
    """A scene from its composed config (plain data): its `cars`, and those of its `traffic` block where it has
    one; ConfigError naming a bad setting."""
    values = dict(values)
    traffic = values.pop("traffic", None)
    if traffic is not None:
        spec = build_params(TrafficSpec, traffic, "scene.traffic")
        generated = [asdict(car) for car in traffic_cars(spec, float(values.get("fps", 25.0)))]
        values["cars"] = list(values.get("cars") or []) + generated
    return SceneSpec.from_dict(values)

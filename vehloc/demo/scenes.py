"""The names of Table 2's scenes in `conf/scene/` (import-light: a CLI checks its settings against them before its
work's modules load)."""

POSES = tuple(f"{distance}_{angle}" for distance in ("middle", "close") for angle in ("0", "30", "minus30"))
"""The paper's six poses: two distances, three angles."""
SIDE_ON_SCENES = tuple(f"table2_{pose}" for pose in POSES)
"""The six poses seen side-on (the wheel branch)."""
PLATE_SCENES = tuple(f"table2_plate_{pose}" for pose in POSES)
"""The six poses with the plate towards the camera (the plate branch)."""
TABLE2_SCENES = SIDE_ON_SCENES + PLATE_SCENES
"""Table 2's twelve scenes: the side-on six, then the plate's six."""

"""A moving vehicle's paper placement against its own path (`pipeline.max_key_points_path_gap_deg`): a box whose
length axis crosses the track's path came from key points that were not the vehicle's and is not taken."""

from __future__ import annotations

import numpy as np
import pytest

from vehloc.geometry.keypoints import Placement
from vehloc.geometry.motion import PathHeading
from vehloc.geometry.outcome import NotPlaced, ReasonCode
from vehloc.geometry.pipeline.key_points import along_path
from vehloc.geometry.pipeline.settings import PipelineParams
from vehloc.geometry.placement import VehicleBox

PATH = PathHeading(heading_deg=90.0, sigma_deg=0.2, jitter_px=0.5, points=30, extent_mm=12000.0, speed_sigmas=40.0)


def placement(heading_deg: float) -> Placement:
    box = VehicleBox(np.array([-3400.0, 1960.0]), heading_deg, 4800.0, 1800.0)
    return Placement(box, "plate", np.array([-3400.0, 4360.0]), np.array([-3400.0, 3360.0]), 2400.0)


@pytest.mark.parametrize("heading_deg", [90.0, 98.0, 82.0, 270.0, -87.0])
def test_a_placement_along_the_path_is_kept_whichever_way_it_faces(heading_deg: float):
    kept = placement(heading_deg)
    assert along_path(kept, PATH, 10.0) is kept


@pytest.mark.parametrize(("heading_deg", "gap_deg"), [(-28.5, 61.5), (0.0, 90.0), (101.0, 11.0), (258.0, 12.0)])
def test_a_placement_across_the_path_is_refused_saying_how_far_off(heading_deg: float, gap_deg: float):
    refused = along_path(placement(heading_deg), PATH, 10.0)
    assert isinstance(refused, NotPlaced) and refused.code == ReasonCode.KEY_POINTS_OFF_PATH
    assert refused.message == f"the plate branch's box lies {gap_deg:.0f} deg off the track's path"


def test_the_gap_comes_from_the_config():
    assert PipelineParams.from_config().max_key_points_path_gap_deg == 10.0
    assert PipelineParams.from_config(max_key_points_path_gap_deg=3.0).max_key_points_path_gap_deg == 3.0

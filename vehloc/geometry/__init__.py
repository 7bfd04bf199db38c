"""Camera model, road-plane homography and the monocular localization geometry."""

"""File formats: control and observation CSV, calibration JSON, images, video frames."""

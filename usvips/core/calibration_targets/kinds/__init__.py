"""One module per calibration-target kind; each defines its class, which registers itself."""

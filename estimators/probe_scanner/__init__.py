"""A rotary probe scanner's (frame tracer's) calibration with a rounded-square opening."""

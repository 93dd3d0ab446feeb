"""The thesis's measured data, shipped inside the wheel as ``fitdf._bundled``."""

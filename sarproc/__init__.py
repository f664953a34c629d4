"""sarproc: SAR point-target simulation, focusing and quality evaluation."""

__version__ = "0.1.0"

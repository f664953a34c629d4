"""The product contract: units, configuration, radar metadata, the Product model, HDF5 I/O,
image frames and the beam geometry shared by the simulator and the focusers.

Imports nothing above it (no dsp, quality, focus, simulation or cli).
"""

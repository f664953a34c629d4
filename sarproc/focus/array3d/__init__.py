"""Linear-array down-looking 3D SAR by elevation-angle compression (Du, Wang, Hong, Wu 2010,
paper 004)."""

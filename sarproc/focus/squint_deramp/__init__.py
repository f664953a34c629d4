"""Squint spotlight two-step imaging via azimuth deramping (An, Li, Huang, Zhou 2012, paper 000):
preprocess (Doppler-centroid correction), coarse_focus (SPECAN), fine_focus (modified Stolt +
flow 1 / modified NLCS), with the Stolt mapping and the NLCS coefficients in their own modules.
"""

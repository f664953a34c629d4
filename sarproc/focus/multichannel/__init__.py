"""Azimuth multichannel squint SAR (paper 003, Xu et al.): reconstruction of moving targets at N x PRF."""

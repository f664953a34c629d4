"""Polar-format family of paper 002 (Nie 2016): ``sarproc pfa2``.

phase_history (range compression, motion compensation with the varied gate, eq. 3), dealias
(sliding-spotlight sub-aperture de-aliasing, Fig. 2), polar (LOSPI polar format and its inverse,
eqs. 4-6), two_step (beam-segmentation two-step PFA, Figs. 3-5, eqs. 7-10; one pure task per
sub-image), chain (the ``pfa2:`` parameters and the driver).
"""

"""A batched 2-D frame finite-element engine and the SAIL arm built with it.

Layout follows the maths: :mod:`.elements` (one beam's stiffness),
:mod:`.frame` (assembly, solve and recovery over a batch of poses),
:mod:`.model` (the SAIL arm as a frame) and :mod:`.response` (what a user
reads off a solution: torques, load-cell signals, stresses).
"""

"""A batched 2-D frame finite-element engine and the SAIL arm built with it.

Layout follows the maths: :mod:`.elements` (one beam's stiffness),
:mod:`.frame` (assembly, solve and recovery over a batch of poses),
:mod:`.model` (the SAIL arm as a frame) and :mod:`.response` (what a user
reads off a solution: torques, load-cell signals, stresses).
"""

from .._lazy import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "elements": (
        "flexibility_stiffness", "local_stiffness", "rotation_patterns", "shear_parameter", "to_global", "to_local",
    ),
    "frame": (
        "CHUNK", "GROUND", "Frame", "FrameSolution", "assemble", "assemble_basis", "end_forces", "make_frame",
        "matrix_basis", "member_basis", "monomials", "reactions", "solve",
    ),
    "model": (
        "JOINT_SLOTS", "JOINTS", "LOADCELL_MEMBERS", "MEMBER_AXIS", "MEMBER_LINK", "MEMBERS", "NODES", "ROOT_MEMBERS",
        "ArmModel", "build_model", "member_lengths", "node_positions",
    ),
    "modes": (
        "DEFAULT_MODES", "MODES_CHUNK", "SUBSPACE_GUARD", "SUBSPACE_MAX_STEPS", "SUBSPACE_RESIDUAL", "Modes",
        "arm_frequencies", "arm_mass_basis", "arm_modes", "frame_modes", "local_mass", "lowest_frequencies",
    ),
    "response": (
        "TRANSDUCTION_UNITS", "TRANSDUCTIONS", "ArmResponse", "MemberStresses", "member_stresses", "simulate",
        "simulate_model",
    ),
})

"""The paper's examples in numbers: its tables (Xu & Wriggers, §5.1) and the geometry values that the
demos, the demo meshes (``meshes/generate.py``) and the results page share.

Where the paper is silent (mesh sizes, gaps), the values are our choices, stated in each demo's
docstring and in ``meshes/README.md``.
"""
from __future__ import annotations

#: Paper Table 2 (§5.1): final gap g at u_y = -1 for huhu_lulu with exp(-5 J) scaling;
#: (alpha_r, gamma) -> (mesh 1, mesh 2, mesh 3).
TABLE2: dict[tuple[float, float], tuple[float, float, float]] = {
    (10.0, 1e-4): (8.6882e-3, 8.7000e-3, 7.5000e-3),
    (10.0, 1e-5): (2.8000e-3, 1.9476e-3, 1.7330e-3),
    (10.0, 1e-6): (7.3795e-4, 8.2579e-4, 4.1061e-4),
    (1.0, 1e-4): (7.9000e-3, 7.2327e-3, 7.0869e-3),
    (1.0, 1e-5): (2.1822e-3, 2.1104e-3, 1.7138e-3),
    (1.0, 1e-6): (5.1084e-4, 5.3938e-4, 4.9040e-4),
    (0.1, 1e-4): (7.6000e-3, 7.3281e-3, 7.0544e-3),
    (0.1, 1e-5): (1.8730e-3, 1.8934e-3, 1.7435e-3),
    (0.1, 1e-6): (4.8469e-4, 4.8581e-4, 4.6363e-4),
}
#: exponent beta of the exp(-beta J) scaling in Table 2 and Fig. 4 (Eq. 58)
TABLE2_BETA = 5.0
#: Paper Table 3 (§5.1): final gap for gamma = 1e-6, alpha_r = 10 and the regularizations of
#: Eqs. 9, 15, 16 (unscaled); regularization -> (mesh 1, mesh 2, mesh 3). (The rotation row repeats
#: Table 2's alpha_r = 1 values on meshes 1, 2 and its alpha_r = 10 value on mesh 3, as printed in
#: the paper.)
TABLE3: dict[str, tuple[float, float, float]] = {
    "huhu_lulu": (5.0282e-4, 5.0988e-4, 4.9311e-4),
    "rotation": (5.1084e-4, 5.3938e-4, 4.1061e-4),
    "tan_rotation": (5.1127e-4, 5.4095e-4, 4.0902e-4),
}
TABLE3_GAMMA, TABLE3_ALPHA_R = 1e-6, 10.0
#: Fig. 4: gap and force over the load for several gamma at this alpha_r on this mesh
FIG4_ALPHA_R, FIG4_MESH = 0.1, 3

#: default mesh size h of each demo (``--h``; the demo meshes in meshes/ are made at it)
DEFAULT_H = {"box_self_contact": 0.05, "cbox": 0.05, "punch": 0.05, "multi_object": 0.04}
#: initial gap between the punch tip and the block (§5.3)
PUNCH_GAP = 1.0
#: initial gap between a disc and the block (§5.4)
MULTI_OBJECT_GAP = 0.1

"""The shipped models, installed as package data: where every other module finds them.

    policy/policy.onnx + policy.json   the decision policy (policy/README.md)
    alliance/policy.onnx + policy.json the learned alliance's policy, both robots of a 2v2
                                       (alliance/README.md)
    ringnet.onnx + ringnet.json        the CNN ring detector (ringnet.md); ringnet.pt, its float
                                       weights to fine-tune from, is in the checkout only

Standard library only: jetson.settings reads DEFAULT_POLICY and must not load numpy.
"""

from __future__ import annotations

from pathlib import Path

MODELS_DIR = Path(__file__).resolve().parent
DEFAULT_POLICY = MODELS_DIR / "policy" / "policy.onnx"
ALLIANCE_POLICY = MODELS_DIR / "alliance" / "policy.onnx"
DEFAULT_DETECTOR = MODELS_DIR / "ringnet.onnx"

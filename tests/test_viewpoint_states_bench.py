"""bench/viewpoint_states.py's AUROC, on hand-counted cases (the gate's ranking figure)."""
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench"))
from viewpoint_states import auroc  # noqa: E402


def test_auroc_hand_cases():
    assert auroc([0.9, 0.8, 0.1, 0.2], [1, 1, 0, 0]) == 1.0  # every positive above every negative
    assert auroc([0.1, 0.2, 0.9, 0.8], [1, 1, 0, 0]) == 0.0
    assert auroc([0.5, 0.5, 0.5], [1, 0, 0]) == 0.5  # all tied
    # Positives 0.9 and 0.4, negatives 0.5 and 0.1: pairs won 2 (0.9) + 1 (0.4 > 0.1) of 4.
    assert auroc([0.9, 0.4, 0.5, 0.1], [1, 1, 0, 0]) == pytest.approx(0.75)
    # A tie between a positive and a negative counts half: (1 + 0.5) / 2.
    assert auroc([0.7, 0.3, 0.3], [1, 1, 0]) == pytest.approx(0.75)
    assert auroc([0.1, 0.2], [1, 1]) is None

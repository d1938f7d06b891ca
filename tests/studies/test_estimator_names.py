"""One name per estimator concept in the studies: the shipped filter is
:data:`~ballbot_casadi.sim.embedded.DEFAULT_ESTIMATOR` (no study-local alias), and the
consistency study's ``ADAPTIVE`` / ``MATCHED`` name the filters themselves, so a change of
the shipped default cannot silently re-point the study's adaptive-walk bookkeeping."""

from __future__ import annotations

import studies.consistency as C
import studies.estimators as E
from ballbot_casadi.sim.embedded import ADAPTIVE_VELOCITY, MATCHED_VELOCITY, ESTIMATOR_FILTERS


def test_the_consistency_study_names_the_filters_not_the_default():
    assert C.ADAPTIVE in ADAPTIVE_VELOCITY
    assert C.MATCHED in MATCHED_VELOCITY and C.MATCHED not in ADAPTIVE_VELOCITY
    assert {C.ADAPTIVE, C.MATCHED} <= set(ESTIMATOR_FILTERS)


def test_the_studies_keep_no_alias_of_the_shipped_estimator():
    for module in (C, E):
        assert not hasattr(module, "SHIPPED_ESTIMATOR")
    assert not hasattr(C, "THESIS")

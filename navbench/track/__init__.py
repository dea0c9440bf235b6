"""Pose estimators behind one interface (:class:`navbench.track.base.Estimator`)."""

"""The crowd models P(c|v) sr-crowd learns from players' traces, one module each, behind
one estimator seam (:mod:`~app.core.players.crowd_models.estimator`) and one registry
(:mod:`~app.core.players.crowd_models.registry`); candidates on trial live in
:mod:`~app.core.players.crowd_models.candidates`. docs/player-models.md says why each exists.
"""

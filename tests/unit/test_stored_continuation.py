"""A liquid run continued from a stored end state is the run continued from memory."""

from __future__ import annotations

import numpy as np

from app.core.liquid.particle_lattice import snap_state
from app.liquid.adapter import LiquidDynamics
from app.store.array_codec import decode_arrays, encode_arrays


def test_continuing_from_the_decoded_stored_state_is_bit_identical() -> None:
    dyn = LiquidDynamics("tiny")
    clip = dyn.simulate(dyn.initial_state(), 1)
    assert clip.end_state.tobytes() == snap_state(clip.end_state, dyn.lattice).tobytes()
    stored = decode_arrays(encode_arrays({"end_state": clip.end_state}))["end_state"]
    assert stored.tobytes() == clip.end_state.tobytes()
    from_memory = dyn.simulate(clip.end_state, 2)
    from_store = dyn.simulate(stored, 2)
    assert np.array_equal(from_memory.frames, from_store.frames)
    assert from_memory.end_state.tobytes() == from_store.end_state.tobytes()

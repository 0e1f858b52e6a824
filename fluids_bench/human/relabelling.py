"""Retroactive labels written into copies of recorded episodes (used by `fluids-bench relabel`
and by the offline DAgger of `fluids_bench.human.offline`)."""

from __future__ import annotations

import copy
import math

import numpy as np
from gymnasium import spaces


def relabelled_episodes(episodes, labels, space):
    """Copies of `episodes` with `labels` ((e, t) -> (label, seconds)) as their actions and
    the original actions, flags and label times in the infos."""
    out = []
    for e, ep in enumerate(episodes):
        new = copy.copy(ep)
        new.actions = list(ep.actions)
        new.infos = dict(ep.infos)
        zero = np.zeros_like(np.asarray(ep.actions[0]))
        flags, times, originals = [False], [math.nan], [zero]
        for t in range(len(ep)):
            originals.append(np.asarray(ep.actions[t]))
            if (e, t) in labels:
                label, seconds = labels[(e, t)]
                if isinstance(space, spaces.Discrete):
                    label = np.int64(label)
                new.actions[t] = np.asarray(label, dtype=space.dtype)
                flags.append(True)
                times.append(float(seconds))
            else:
                flags.append(False)
                times.append(math.nan)
        if isinstance(space, spaces.Discrete):
            originals = [int(a) for a in originals]
        new.infos.update(original_action=originals, relabelled=flags, label_time=times)
        out.append(new)
    return out

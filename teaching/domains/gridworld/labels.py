"""Strategy clusters of the delivery yard: two per informative class, one for "other".

Read off the path's own counts, never θ: in a mud yard a path that enters mud goes *through the
mud*, else *around* it; in a dog yard one that enters a cell next to the dog goes *past the dog*,
else *around*; in a cart yard one that moves with the cart *fetched the cart*, else it *carried*
the parcel by hand.  Every path of an "other" yard is "other: deliver".
"""
from __future__ import annotations

import numpy as np

from .environments import CART_CLASS, DOG_CLASS, MUD_CLASS, OTHER

THROUGH_MUD, AROUND_MUD, PAST_DOG, AROUND_DOG, FETCH_CART, CARRY, OTHER_DELIVER, NO_STRATEGY = range(8)
N_CLUSTERS = 7
CLUSTER_NAMES = ("mud: through the mud", "mud: around the mud", "dog: past the dog", "dog: around the dog",
                 "cart: fetch the cart", "cart: carry by hand", "other: deliver", "none of its class's strategies")
CLASS_OF_CLUSTER = np.array([MUD_CLASS, MUD_CLASS, DOG_CLASS, DOG_CLASS, CART_CLASS, CART_CLASS, OTHER])


def strategy_labels(phi: np.ndarray, env_class: np.ndarray) -> np.ndarray:
    """phi (..., 4) counts [carry, cart, mud, near dog], env_class (...) -> (...) int8 cluster."""
    phi = np.asarray(phi)
    cls = np.asarray(env_class)
    out = np.full(cls.shape, NO_STRATEGY, np.int8)
    out[cls == OTHER] = OTHER_DELIVER
    for c, feature, yes, no in ((MUD_CLASS, 2, THROUGH_MUD, AROUND_MUD), (DOG_CLASS, 3, PAST_DOG, AROUND_DOG),
                                (CART_CLASS, 1, FETCH_CART, CARRY)):
        out[(cls == c) & (phi[..., feature] > 0)] = yes
        out[(cls == c) & (phi[..., feature] == 0)] = no
    return out

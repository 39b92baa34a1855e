"""The parts of Gymnasium the environments use, for a machine without it.

With gymnasium importable, hexsim.env uses gymnasium.Env, gymnasium.vector.VectorEnv and
gymnasium.spaces.Box instead, so that its checker, wrappers and make() accept the environments.
"""
import numpy as np


class Box:
    """A box in R^n (gymnasium.spaces.Box's constructor, sample, contains, seed)."""

    def __init__(self, low, high, shape=None, dtype=np.float64, seed=None):
        shape = tuple(shape) if shape is not None else np.shape(low)
        self.dtype = np.dtype(dtype)
        self.low = np.broadcast_to(np.asarray(low, dtype=self.dtype), shape).copy()
        self.high = np.broadcast_to(np.asarray(high, dtype=self.dtype), shape).copy()
        self.shape = shape
        self.np_random = np.random.default_rng(seed)

    def sample(self):
        low = np.where(np.isfinite(self.low), self.low, -1.0)
        high = np.where(np.isfinite(self.high), self.high, 1.0)
        return self.np_random.uniform(low, high).astype(self.dtype)

    def contains(self, x):
        x = np.asarray(x)
        return (x.shape == self.shape and np.can_cast(x.dtype, self.dtype)
                and bool(np.all(x >= self.low) and np.all(x <= self.high)))

    __contains__ = contains

    def seed(self, seed=None):
        self.np_random = np.random.default_rng(seed)
        return [seed]

    def __repr__(self):
        return f"Box({self.low.min()}, {self.high.max()}, {self.shape}, {self.dtype})"


def batch_box(space, n):
    """The space of n stacked samples of `space` (gymnasium.vector.utils.batch_space for a Box)."""
    return Box(np.repeat(space.low[None], n, axis=0), np.repeat(space.high[None], n, axis=0), dtype=space.dtype)


class _Closing:
    """unwrapped, and `with env:` closing it."""

    @property
    def unwrapped(self):
        return self

    def __enter__(self):
        return self

    def __exit__(self, *args):
        self.close()
        return False


class Env(_Closing):
    """gymnasium.Env's interface: reset(seed=, options=) seeds np_random; close, unwrapped, spec."""

    metadata = {"render_modes": []}
    render_mode = None
    spec = None
    np_random = None

    def reset(self, *, seed=None, options=None):
        if seed is not None or self.np_random is None:
            self.np_random = np.random.default_rng(seed)

    def render(self):
        return None

    def close(self):
        pass


class VectorEnv(_Closing):
    """gymnasium.vector.VectorEnv's interface."""

    metadata = {}
    render_mode = None
    spec = None
    closed = False

    def reset(self, *, seed=None, options=None):
        pass

    def close(self, **kwargs):
        self.closed = True

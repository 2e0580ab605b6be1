"""The scikit-learn estimator conventions the runtime's fitted models keep, without scikit-learn.

A node evaluates fitted models with numpy; scikit-learn (and the scipy it loads, about 85 MB
in each process: docs/node-memory.md) is for training, in :mod:`touch_lab`. The models the
nodes use keep scikit-learn's conventions so that the lab's estimators can build on them:
hyper-parameters are the ``__init__`` arguments, stored under their own names
(:class:`Params`: ``get_params`` / ``set_params``), learned attributes end in ``_``, and
using a model before it has them raises :class:`NotFittedError`.
"""

from __future__ import annotations

import inspect
from typing import Any

__all__ = ['NotFittedError', 'Params']


class NotFittedError(ValueError, AttributeError):
    """A model was used before it was fitted or loaded (the bases of scikit-learn's ``NotFittedError``)."""


class Params:
    """``get_params`` / ``set_params`` over the ``__init__`` arguments, as scikit-learn's ``BaseEstimator``."""

    @classmethod
    def _param_names(cls) -> list[str]:
        signature = inspect.signature(cls.__init__)
        return sorted(name for name, p in signature.parameters.items()
                      if name != 'self' and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD))

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        """The hyper-parameters by name (``deep`` is accepted for scikit-learn's signature; none nest)."""
        return {name: getattr(self, name) for name in self._param_names()}

    def set_params(self, **params: Any) -> Params:
        """Set hyper-parameters by name; ValueError naming the valid ones for an unknown name."""
        names = self._param_names()
        for key, value in params.items():
            if key not in names:
                raise ValueError(f'invalid parameter {key!r} for {type(self).__name__}; valid parameters: '
                                 f'{", ".join(names)}')
            setattr(self, key, value)
        return self

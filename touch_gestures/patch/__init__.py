"""Textile patch gestures (sympartner2018 6.2): sliding-window features, one Gaussian mixture per
class (evaluated with numpy), the event rule, model files and the ``patch_gestures`` node. Simulated
people are in :mod:`touch_sim.patch`; training (scikit-learn's EM) and leave-one-subject-out
evaluation in :mod:`touch_lab.patch`.

Per frame::

    model = load_model('config/patch_gestures.npz')
    features, detector = model.features(), model.detector()
    x = features.update(activation)                       # (16, 16) activation -> (12,)
    event = detector.update(model.classifier.log_posterior(x), features.onset_age)
"""

from .classifier import NOT_RECOGNISED, Detection, EventDetector, GestureMixtures
from .features import FEATURE_NAMES, WindowFeatures, window_features
from .model_io import ModelFileError, PatchModel, load_model, save_model

__all__ = ['FEATURE_NAMES', 'NOT_RECOGNISED', 'Detection', 'EventDetector', 'GestureMixtures', 'ModelFileError',
           'PatchModel', 'WindowFeatures', 'load_model', 'save_model', 'window_features']

"""The paper's model (eq. 1 thin-wire blades, eq. 2 body/blade/alpha) and the radar (the model's extensions:
:mod:`microdoppler.causes`)."""

from .model import Scaling, SynthesisConfig, Track, add_noise, synthesize
from .radar import DRONE_MODELS, DroneModel, Radar

__all__ = ["Radar", "DroneModel", "DRONE_MODELS", "SynthesisConfig", "Scaling", "Track", "synthesize", "add_noise"]

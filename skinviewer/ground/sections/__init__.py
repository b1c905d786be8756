"""The techniques' settings sections: the registry below composes them into ``Settings`` (issue 28).

Each technique declares its section in its own module here (``deon.py``: every field with its
default, range, panel label, unit and tooltip; see ``base.field``); ``TechniqueSections`` lists
them, one line each, in the viewer's order, and its field names are the values ``technique`` may
take. Adding a technique's settings: a module here and one line in ``TechniqueSections``. They sit
in ``ground/`` (not ``techniques/``) because passes, the scene layer and the ground truth read them.
"""
from __future__ import annotations

from pydantic import Field

from skinviewer.ground.sections.base import Section
from skinviewer.ground.sections.burley import BurleySettings
from skinviewer.ground.sections.burley2 import Burley2Settings
from skinviewer.ground.sections.deon import DeonSettings
from skinviewer.ground.sections.gosselin import GosselinSettings
from skinviewer.ground.sections.penner import PennerSettings
from skinviewer.ground.sections.phong import PhongSettings
from skinviewer.ground.sections.separable import SeparableSettings
from skinviewer.ground.sections.ssss import SsssSettings


class TechniqueSections(Section):
    """The registry: one section per technique, named as the technique (``settings.technique``)."""
    phong: PhongSettings = Field(default_factory=PhongSettings)
    gosselin: GosselinSettings = Field(default_factory=GosselinSettings)
    deon: DeonSettings = Field(default_factory=DeonSettings)
    ssss: SsssSettings = Field(default_factory=SsssSettings)
    separable: SeparableSettings = Field(default_factory=SeparableSettings)
    burley: BurleySettings = Field(default_factory=BurleySettings)
    burley2: Burley2Settings = Field(default_factory=Burley2Settings)
    penner: PennerSettings = Field(default_factory=PennerSettings)


TECHNIQUE_NAMES: tuple[str, ...] = tuple(TechniqueSections.model_fields)

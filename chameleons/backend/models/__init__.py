"""SQLAlchemy models, one per module; importing this package registers them all."""

from chameleons.backend.models.base import Base
from chameleons.backend.models.booth_check import BoothCheck
from chameleons.backend.models.display_link import DisplayLink
from chameleons.backend.models.event import Event
from chameleons.backend.models.instrument import CodedAnnotation, InstrumentStream
from chameleons.backend.models.interaction import Interaction
from chameleons.backend.models.interaction_synchrony import InteractionSynchrony
from chameleons.backend.models.participant import Participant
from chameleons.backend.models.plan_row import PlanRow
from chameleons.backend.models.questionnaire_response import QuestionnaireResponse
from chameleons.backend.models.recording import Recording
from chameleons.backend.models.session import Session
from chameleons.backend.models.staff_session import StaffSession
from chameleons.backend.models.staff_user import StaffUser
from chameleons.backend.models.study import Study
from chameleons.backend.models.suggestion import Suggestion
from chameleons.backend.models.video import ParticipantVideo, VideoChunk

__all__ = [
    "Base",
    "BoothCheck",
    "CodedAnnotation",
    "DisplayLink",
    "Event",
    "InstrumentStream",
    "Interaction",
    "InteractionSynchrony",
    "Participant",
    "ParticipantVideo",
    "PlanRow",
    "QuestionnaireResponse",
    "Recording",
    "Session",
    "StaffSession",
    "StaffUser",
    "Study",
    "Suggestion",
    "VideoChunk",
]

from tests.backend.sessions.conftest import phone, pi, study_id, wizard

__all__ = ["phone", "pi", "study_id", "wizard"]

"""The realtime pipeline of one booth. Imports nothing from ``chameleons.backend``."""

"""Planning a study: power by simulation and the preregistration document."""

"""Loop analysis: plants (``plant``), harmonic balance with Loeb stability (``harmonic``),
the closed loop simulated in time (``simulate``) and the two compared (``check``)."""

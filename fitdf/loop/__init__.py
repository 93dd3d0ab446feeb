"""Loop analysis: plants (``plant``), harmonic balance (``harmonic``, with its inputs in
``nonlinearity``, results in ``response`` and the critical-gain search in ``critical``),
the loop's elements in time (``elements``), the closed loop simulated (``simulate``), the
two compared (``check``), and the limit cycles of a fitted core (``fitted``)."""

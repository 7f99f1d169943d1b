from pythonfmu import Fmi2Causality, Fmi2Variability, Fmi2Slave, Real

class vanderpol_py(Fmi2Slave):
    author = "lash tests"
    description = "Van der Pol oscillator, forward Euler at 1e-3 s (a PythonFMU-built FMU for lash's importer tests)"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.x0 = 2.0
        self.x1 = 0.0
        self.mu = 1.0
        self.register_variable(Real("x0", causality=Fmi2Causality.output))
        self.register_variable(Real("x1", causality=Fmi2Causality.output))
        self.register_variable(Real("mu", causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable))

    def do_step(self, current_time, step_size):
        # Whole steps of exactly 1e-3 s: float noise on step_size does not change the result.
        h = 1e-3
        for _ in range(max(1, round(step_size / h))):
            d0 = self.x1
            d1 = self.mu * (1 - self.x0 * self.x0) * self.x1 - self.x0
            self.x0 += h * d0
            self.x1 += h * d1
        return True

/* A tiny FMI 2.0 co-simulation FMU written without lash, made to show how a master reaches the
 * initial values of a loop: two inputs u[1], u[2] fed straight through to the outputs
 *   y = x + gain u,
 * a state x that takes its input into its initial value,
 *   x = x_start + pull u  (in initialization mode, and frozen when it is left),
 * and x' = -x + u afterwards (forward Euler at a fixed internal step of 1e-3 s). Two instances in a
 * loop reach different initial values under an ordered and an iterated initialization, so a run
 * tells which one a master does. late_parameters counts the parameter values set in
 * initialization mode rather than before it (where FMI puts start values). Value references:
 * 0-1 u[1..2], 2-3 y[1..2], 4 gain, 5 pull, 6-7 x_start[1..2], 8 late_parameters. The fmi2 types
 * come from ../fmi2_types.h. */
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "../fmi2_types.h"

#define GUID "{3f0d6a52-7c1e-4d2b-9a61-feedf0000a0a}"
#define SOLVER_STEP 1e-3

typedef struct {
    double u[2], x[2], x_start[2], gain, pull, late;
    int entered, initialized;
} Model;

/* The state: in initialization mode it follows the input; afterwards it is integrated. */
static double state(const Model *m, int i) {
    return m->initialized ? m->x[i] : m->x_start[i] + m->pull * m->u[i];
}

const char *fmi2GetTypesPlatform(void) { return "default"; }
const char *fmi2GetVersion(void) { return "2.0"; }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cats[]) {
    (void)c; (void)on; (void)n; (void)cats;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String resources,
                              const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean logging) {
    (void)name; (void)resources; (void)cb; (void)visible; (void)logging;
    if (type != fmi2CoSimulation || !guid || strcmp(guid, GUID) != 0) return NULL;
    Model *m = calloc(1, sizeof(Model));
    if (!m) return NULL;
    m->gain = 0.5;
    m->pull = 1.0;
    m->x_start[0] = 1.0;
    m->x_start[1] = 2.0;
    return m;
}

void fmi2FreeInstance(fmi2Component c) { free(c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tol_defined, fmi2Real tol, fmi2Real start,
                               fmi2Boolean stop_defined, fmi2Real stop) {
    (void)tol_defined; (void)tol; (void)start; (void)stop_defined; (void)stop;
    return c ? fmi2OK : fmi2Error;
}
fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    if (!c) return fmi2Error;
    ((Model *)c)->entered = 1;
    return fmi2OK;
}
fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Model *m = c;
    if (!m) return fmi2Error;
    m->x[0] = state(m, 0);
    m->x[1] = state(m, 1);
    m->initialized = 1;
    return fmi2OK;
}
fmi2Status fmi2Terminate(fmi2Component c) { return c ? fmi2OK : fmi2Error; }
fmi2Status fmi2Reset(fmi2Component c) { return fmi2Error; }

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    Model *m = c;
    if (!m || (n && (!vr || !value))) return fmi2Error;
    for (size_t i = 0; i < n; i++) {
        switch (vr[i]) {
        case 0: case 1: value[i] = m->u[vr[i]]; break;
        case 2: case 3: value[i] = state(m, vr[i] - 2) + m->gain * m->u[vr[i] - 2]; break;
        case 4: value[i] = m->gain; break;
        case 5: value[i] = m->pull; break;
        case 6: case 7: value[i] = m->x_start[vr[i] - 6]; break;
        case 8: value[i] = m->late; break;
        default: return fmi2Error;
        }
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    Model *m = c;
    if (!m || (n && (!vr || !value))) return fmi2Error;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= 4 && vr[i] <= 7 && m->entered) m->late += 1;
        if (vr[i] <= 1) m->u[vr[i]] = value[i];
        else if (vr[i] == 4 && !m->initialized) m->gain = value[i];
        else if (vr[i] == 5 && !m->initialized) m->pull = value[i];
        else if ((vr[i] == 6 || vr[i] == 7) && !m->initialized) m->x_start[vr[i] - 6] = value[i];
        else return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean no_prior) {
    (void)t; (void)no_prior;
    Model *m = c;
    if (!m || !m->initialized || !(h > 0)) return fmi2Error;
    long steps = (long)(h / SOLVER_STEP + 0.5);
    if (steps < 1) steps = 1;
    for (long k = 0; k < steps; k++)
        for (int i = 0; i < 2; i++) m->x[i] += SOLVER_STEP * (m->u[i] - m->x[i]);
    return fmi2OK;
}

/* The rest of fmi2Functions.h: not supported, answered with fmi2Error. */
#define UNSUPPORTED(decl) decl { return fmi2Error; }
UNSUPPORTED(fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference v[], size_t n, fmi2Integer x[]))
UNSUPPORTED(fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference v[], size_t n, fmi2Boolean x[]))
UNSUPPORTED(fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference v[], size_t n, fmi2String x[]))
UNSUPPORTED(fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference v[], size_t n, const fmi2Integer x[]))
UNSUPPORTED(fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference v[], size_t n, const fmi2Boolean x[]))
UNSUPPORTED(fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference v[], size_t n, const fmi2String x[]))
UNSUPPORTED(fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s))
UNSUPPORTED(fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s))
UNSUPPORTED(fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s))
UNSUPPORTED(fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n))
UNSUPPORTED(fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n))
UNSUPPORTED(fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s))
UNSUPPORTED(fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference a[], size_t na,
                                                    const fmi2ValueReference b[], size_t nb, const fmi2Real d[], fmi2Real r[]))
UNSUPPORTED(fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference v[], size_t n,
                                                   const fmi2Integer o[], const fmi2Real x[]))
UNSUPPORTED(fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference v[], size_t n,
                                                    const fmi2Integer o[], fmi2Real x[]))
UNSUPPORTED(fmi2Status fmi2CancelStep(fmi2Component c))
UNSUPPORTED(fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind k, fmi2Status *x))
UNSUPPORTED(fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind k, fmi2Real *x))
UNSUPPORTED(fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind k, fmi2Integer *x))
UNSUPPORTED(fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind k, fmi2Boolean *x))
UNSUPPORTED(fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind k, fmi2String *x))

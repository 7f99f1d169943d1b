/* A tiny FMI 2.0 co-simulation FMU written without lash: the Van der Pol oscillator
 *   x0' = x1,  x1' = mu (1 - x0^2) x1 - x0,
 * integrated with forward Euler at a fixed internal step of 1e-3 s (ten steps per doStep of
 * 0.01 s), like the Modelica Association's Reference FMU of the same name. It is the third-party
 * FMU of lash's importer tests and of `lash bench fmu` (the per-step cost of the importer).
 * Value references: 0 x0, 1 x1, 2 mu, 3 stop_at (once reached, fmi2DoStep answers fmi2Discard and
 * fmi2GetBooleanStatus(fmi2Terminated) is true: the FMU asks the master to stop), 4 steps (Integer
 * output: doStep calls), 5 positive (Boolean output: x0 > 0), 6 label (String parameter), 7 fault and
 * 8 fault_at (parameters: from the step that starts at fault_at on, fault 1 calls abort(), 2
 * dereferences a null pointer, 3 loops for ever: the misbehaving FMUs of the isolation tests).
 * The fmi2 types come from ../fmi2_types.h. */
#include <signal.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "../fmi2_types.h"

#define GUID "{8c4e810f-3df3-4a00-8276-176fa3c9f000}"
#define SOLVER_STEP 1e-3

typedef struct {
    double x0, x1, mu, stop_at, fault, fault_at, time;
    int initialized, terminated, steps;
    char label[64];
    const fmi2CallbackFunctions *cb;
    char name[64];
} Model;

static void log_error(Model *m, const char *message) {
    if (m && m->cb && m->cb->logger)
        m->cb->logger(m->cb->componentEnvironment, m->name, fmi2Error, "logStatusError", "%s: %s", m->name, message);
}

const char *fmi2GetTypesPlatform(void) { return "default"; }
const char *fmi2GetVersion(void) { return "2.0"; }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cats[]) {
    (void)c; (void)on; (void)n; (void)cats;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String resources,
                              const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean logging) {
    (void)resources; (void)visible; (void)logging;
    if (type != fmi2CoSimulation || !guid || strcmp(guid, GUID) != 0) return NULL;
    Model *m = calloc(1, sizeof(Model));
    if (!m) return NULL;
    m->x0 = 2.0;
    m->x1 = 0.0;
    m->mu = 1.0;
    m->stop_at = 1e9;
    m->fault_at = 1e9;
    strcpy(m->label, "vanderpol");
    m->cb = cb;
    strncpy(m->name, name ? name : "vanderpol", sizeof m->name - 1);
    return m;
}

void fmi2FreeInstance(fmi2Component c) { free(c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tol_defined, fmi2Real tol, fmi2Real start,
                               fmi2Boolean stop_defined, fmi2Real stop) {
    (void)tol_defined; (void)tol; (void)stop_defined; (void)stop;
    if (!c) return fmi2Error;
    ((Model *)c)->time = start;
    return fmi2OK;
}
fmi2Status fmi2EnterInitializationMode(fmi2Component c) { return c ? fmi2OK : fmi2Error; }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    if (!c) return fmi2Error;
    ((Model *)c)->initialized = 1;
    return fmi2OK;
}
fmi2Status fmi2Terminate(fmi2Component c) { return c ? fmi2OK : fmi2Error; }
fmi2Status fmi2Reset(fmi2Component c) {
    if (!c) return fmi2Error;
    Model *m = c;
    m->x0 = 2.0; m->x1 = 0.0; m->mu = 1.0; m->stop_at = 1e9; m->time = 0.0; m->initialized = 0; m->terminated = 0; m->steps = 0;
    strcpy(m->label, "vanderpol");
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    Model *m = c;
    if (!m || (n && (!vr || !value))) return fmi2Error;
    for (size_t i = 0; i < n; i++) {
        switch (vr[i]) {
        case 0: value[i] = m->x0; break;
        case 1: value[i] = m->x1; break;
        case 2: value[i] = m->mu; break;
        case 3: value[i] = m->stop_at; break;
        case 7: value[i] = m->fault; break;
        case 8: value[i] = m->fault_at; break;
        default: log_error(m, "unknown value reference"); return fmi2Error;
        }
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    Model *m = c;
    if (!m || (n && (!vr || !value))) return fmi2Error;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == 2 && !m->initialized) m->mu = value[i];
        else if (vr[i] == 3 && !m->initialized) m->stop_at = value[i];
        else if (vr[i] == 7 && !m->initialized) m->fault = value[i];
        else if (vr[i] == 8 && !m->initialized) m->fault_at = value[i];
        else { log_error(m, "only the parameters mu and stop_at can be set, before initialization"); return fmi2Error; }
    }
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean no_prior) {
    (void)no_prior;
    Model *m = c;
    if (!m || !m->initialized || m->terminated || !(h > 0)) return fmi2Error;
    if (t >= m->fault_at - 1e-12) {
        if (m->fault == 1) abort();
        if (m->fault == 2) { volatile int *nowhere = NULL; *nowhere = 1; }
        if (m->fault == 3) { volatile int spin = 1; while (spin) {} }
    }
    /* Whole solver steps of exactly SOLVER_STEP: float noise on h (a master that sends
     * t_{k+1} - t_k) does not change the result. */
    long n = (long)(h / SOLVER_STEP + 0.5);
    if (n < 1) n = 1;
    for (long k = 0; k < n; k++) {
        double d0 = m->x1;
        double d1 = m->mu * (1.0 - m->x0 * m->x0) * m->x1 - m->x0;
        m->x0 += SOLVER_STEP * d0;
        m->x1 += SOLVER_STEP * d1;
    }
    m->time = t + h;
    m->steps += 1;
    if (m->time >= m->stop_at - 1e-12) {
        m->terminated = 1;
        return fmi2Discard;
    }
    return fmi2OK;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind k, fmi2Boolean *x) {
    Model *m = c;
    if (!m || !x || k != fmi2Terminated) return fmi2Discard;
    *x = m->terminated;
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind k, fmi2Real *x) {
    Model *m = c;
    if (!m || !x || k != fmi2LastSuccessfulTime) return fmi2Discard;
    *x = m->time;
    return fmi2OK;
}


fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer value[]) {
    Model *m = c;
    if (!m || (n && (!vr || !value))) return fmi2Error;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == 4) value[i] = m->steps;
        else { log_error(m, "fmi2GetInteger: not an Integer variable"); return fmi2Error; }
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean value[]) {
    Model *m = c;
    if (!m || (n && (!vr || !value))) return fmi2Error;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == 5) value[i] = m->x0 > 0;
        else { log_error(m, "fmi2GetBoolean: not a Boolean variable"); return fmi2Error; }
    }
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String value[]) {
    Model *m = c;
    if (!m || (n && (!vr || !value))) return fmi2Error;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == 6) value[i] = m->label;
        else { log_error(m, "fmi2GetString: not a String variable"); return fmi2Error; }
    }
    return fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String value[]) {
    Model *m = c;
    if (!m || (n && (!vr || !value))) return fmi2Error;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == 6 && !m->initialized && value[i] && strlen(value[i]) < sizeof m->label) strcpy(m->label, value[i]);
        else { log_error(m, "fmi2SetString: label (under 64 bytes) can be set before initialization"); return fmi2Error; }
    }
    return fmi2OK;
}

/* The rest of fmi2Functions.h: not supported, answered with fmi2Error. */
#define UNSUPPORTED(decl) decl { return fmi2Error; }
UNSUPPORTED(fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference v[], size_t n, const fmi2Integer x[]))
UNSUPPORTED(fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference v[], size_t n, const fmi2Boolean x[]))
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
UNSUPPORTED(fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind k, fmi2Integer *x))
UNSUPPORTED(fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind k, fmi2String *x))

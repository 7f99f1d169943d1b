/* A small FMI 3.0 co-simulation FMU written without lash, for the importer's tests:
 *   x' = v,  v' = (force - k x) / 1 kg,
 * symplectic Euler at a fixed internal step of 1e-3 s. Its value references are sparse, listed out
 * of order and aliased (x and position share 1003), so a master that confuses a value reference
 * with a position in the variable list reads the wrong variable. Two parameters exercise the
 * step outcomes: stop_at (terminateSimulation once reached) and return_early_at (earlyReturn
 * with lastSuccessfulTime at that time). Variables of other types than Float64 exercise the
 * importer's typed access: steps (Int32 output: doStep calls), moving (Boolean output:
 * |v| > 0.5), ticks (Int64 output: internal solver steps), x32 (Float32 output), kicks_seen
 * (Int32 output: the sum of the kick input over the steps), kick (Int32 input, added to the
 * force), gain (UInt8 parameter, multiplies the force input), gear (Enumeration parameter,
 * multiplies k), label (String parameter, echoed by the String output label_out). A structural
 * parameter sizes an array: modes (Float64 output, n elements: modes[i] = (i + 1) x), n (UInt64
 * structural parameter, set in configuration mode, 0 to 64). Bytes: blob (Binary parameter, up to
 * 64 bytes) echoed by the Binary output blob_out; blob_in (Binary input) whose length and first
 * byte are the Int32 outputs blob_in_length and blob_in_first. The remaining integer types are
 * outputs derived from the step count s: wave8 (Int8, (s mod 200) - 100), count16 (UInt16,
 * 1000 s mod 65536), wave16 (Int16, 300 (s mod 200) - 30000), count32 (UInt32, 4e7 s mod 2^32).
 * Self-contained: the fmi3 types are declared here. */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <math.h>

typedef void *fmi3Instance;
typedef void *fmi3InstanceEnvironment;
typedef void *fmi3FMUState;
typedef uint32_t fmi3ValueReference;
typedef double fmi3Float64;
typedef bool fmi3Boolean;
typedef const char *fmi3String;
typedef enum { fmi3OK, fmi3Warning, fmi3Discard, fmi3Error, fmi3Fatal } fmi3Status;
typedef void (*fmi3LogMessageCallback)(fmi3InstanceEnvironment, fmi3Status, fmi3String, fmi3String);

#define TOKEN "{5b1e7a52-9c1f-4d0e-a3f3-0a1c2e3d4f50}"
#define SOLVER_STEP 1e-3

enum { VR_X = 1003, VR_V = 17, VR_ENERGY = 2, VR_K = 5, VR_FORCE = 3, VR_STOP = 99, VR_EARLY = 98, VR_TIME = 0 };
enum { VR_N = 60, VR_MODES = 61, MAX_MODES = 64 };
enum { VR_WAVE8 = 80, VR_COUNT16 = 81, VR_WAVE16 = 82, VR_COUNT32 = 83 };
enum { VR_BLOB = 70, VR_BLOB_OUT = 71, VR_BLOB_IN = 72, VR_BLOB_IN_LENGTH = 73, VR_BLOB_IN_FIRST = 74, MAX_BLOB = 64 };
enum { VR_STEPS = 40, VR_MOVING = 41, VR_TICKS = 44, VR_X32 = 46, VR_KICKS = 48, VR_KICK = 47, VR_GAIN = 42,
       VR_GEAR = 45, VR_LABEL = 43, VR_LABEL_OUT = 49 };

typedef struct {
    double x, v, k, force, stop_at, early_at, time;
    int32_t steps, kick, kicks_seen;
    int64_t ticks, gear;
    uint8_t gain;
    uint64_t n;
    uint8_t blob[64], blob_in[64];
    size_t blob_size, blob_in_size;
    char label[64];
    int initialized, configuring;
    fmi3InstanceEnvironment env;
    fmi3LogMessageCallback log;
} Model;

static void fail(Model *m, const char *message) {
    if (m && m->log) m->log(m->env, fmi3Error, "logStatusError", message);
}

static double *slot(Model *m, fmi3ValueReference vr) {
    switch (vr) {
    case VR_X: return &m->x;
    case VR_V: return &m->v;
    case VR_K: return &m->k;
    case VR_FORCE: return &m->force;
    case VR_STOP: return &m->stop_at;
    case VR_EARLY: return &m->early_at;
    case VR_TIME: return &m->time;
    default: return NULL;
    }
}

const char *fmi3GetVersion(void) { return "3.0"; }
fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n, const fmi3String cats[]) {
    (void)c; (void)on; (void)n; (void)cats;
    return fmi3OK;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String resources, fmi3Boolean visible,
                                         fmi3Boolean logging, fmi3Boolean event_mode, fmi3Boolean early_allowed,
                                         const fmi3ValueReference required[], size_t n_required,
                                         fmi3InstanceEnvironment env, fmi3LogMessageCallback log, void *intermediate) {
    (void)name; (void)resources; (void)visible; (void)logging; (void)event_mode; (void)early_allowed;
    (void)required; (void)n_required; (void)intermediate;
    if (!token || strcmp(token, TOKEN) != 0) return NULL;
    Model *m = calloc(1, sizeof(Model));
    if (!m) return NULL;
    m->x = 1.0; m->k = 4.0; m->stop_at = 1e9; m->early_at = 1e9;
    m->gain = 1; m->gear = 1; m->n = 3;
    strcpy(m->label, "oscillator");
    m->env = env; m->log = log;
    return m;
}
fmi3Instance fmi3InstantiateModelExchange(fmi3String a, fmi3String b, fmi3String c, fmi3Boolean d, fmi3Boolean e,
                                          fmi3InstanceEnvironment f, fmi3LogMessageCallback g) {
    (void)a; (void)b; (void)c; (void)d; (void)e; (void)f; (void)g;
    return NULL;
}
fmi3Instance fmi3InstantiateScheduledExecution(fmi3String a, fmi3String b, fmi3String c, fmi3Boolean d, fmi3Boolean e,
                                               fmi3InstanceEnvironment f, fmi3LogMessageCallback g, void *h) {
    (void)a; (void)b; (void)c; (void)d; (void)e; (void)f; (void)g; (void)h;
    return NULL;
}
void fmi3FreeInstance(fmi3Instance c) { free(c); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean tol_defined, fmi3Float64 tol, fmi3Float64 start,
                                       fmi3Boolean stop_defined, fmi3Float64 stop) {
    (void)tol_defined; (void)tol; (void)stop_defined; (void)stop;
    if (!c) return fmi3Error;
    ((Model *)c)->time = start;
    return fmi3OK;
}
fmi3Status fmi3ExitInitializationMode(fmi3Instance c) {
    if (!c) return fmi3Error;
    ((Model *)c)->initialized = 1;
    return fmi3OK;
}
fmi3Status fmi3EnterStepMode(fmi3Instance c) { return c ? fmi3OK : fmi3Error; }
fmi3Status fmi3EnterConfigurationMode(fmi3Instance c) {
    Model *m = c;
    if (!m || m->initialized) return fmi3Error;
    m->configuring = 1;
    return fmi3OK;
}
fmi3Status fmi3ExitConfigurationMode(fmi3Instance c) {
    Model *m = c;
    if (!m || !m->configuring) return fmi3Error;
    m->configuring = 0;
    return fmi3OK;
}
fmi3Status fmi3GetUInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, uint64_t value[], size_t nv) {
    Model *m = c;
    if (!m || nv != n || (n && (!vr || !value))) return fmi3Error;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == VR_N) value[i] = m->n;
        else { fail(m, "fmi3GetUInt64: not a UInt64 variable"); return fmi3Error; }
    }
    return fmi3OK;
}
fmi3Status fmi3SetUInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const uint64_t value[], size_t nv) {
    Model *m = c;
    if (!m || nv != n || (n && (!vr || !value))) return fmi3Error;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == VR_N && m->configuring && value[i] <= MAX_MODES) m->n = value[i];
        else { fail(m, "fmi3SetUInt64: n (0 to 64) is set in configuration mode"); return fmi3Error; }
    }
    return fmi3OK;
}
fmi3Status fmi3Terminate(fmi3Instance c) { return c ? fmi3OK : fmi3Error; }
fmi3Status fmi3Reset(fmi3Instance c) {
    Model *m = c;
    if (!m) return fmi3Error;
    m->x = 1.0; m->v = 0.0; m->k = 4.0; m->force = 0.0; m->stop_at = 1e9; m->early_at = 1e9;
    m->steps = 0; m->kick = 0; m->kicks_seen = 0; m->ticks = 0; m->gear = 1; m->gain = 1; m->n = 3;
    strcpy(m->label, "oscillator");
    m->time = 0.0; m->initialized = 0;
    return fmi3OK;
}

fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 value[], size_t nv) {
    Model *m = c;
    if (!m || (n && (!vr || !value))) return fmi3Error;
    size_t j = 0;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == VR_MODES) {
            if (j + m->n > nv) { fail(m, "fmi3GetFloat64: too few values for modes"); return fmi3Error; }
            for (uint64_t k = 0; k < m->n; k++) value[j++] = (double)(k + 1) * m->x;
            continue;
        }
        if (j >= nv) { fail(m, "fmi3GetFloat64: too few values"); return fmi3Error; }
        if (vr[i] == VR_ENERGY) { value[j++] = 0.5 * m->v * m->v + 0.5 * m->k * m->x * m->x; continue; }
        double *p = slot(m, vr[i]);
        if (!p) { fail(m, "fmi3GetFloat64: unknown value reference"); return fmi3Error; }
        value[j++] = *p;
    }
    if (j != nv) { fail(m, "fmi3GetFloat64: wrong number of values"); return fmi3Error; }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Float64 value[],
                          size_t nv) {
    Model *m = c;
    if (!m || nv != n || (n && (!vr || !value))) return fmi3Error;
    for (size_t i = 0; i < n; i++) {
        int parameter = vr[i] == VR_K || vr[i] == VR_STOP || vr[i] == VR_EARLY;
        if (vr[i] == VR_FORCE || (parameter && !m->initialized)) {
            if (!isfinite(value[i]) || (vr[i] == VR_K && !(value[i] > 0))) {
                fail(m, "fmi3SetFloat64: k must be > 0 and values finite");
                return fmi3Error;
            }
            *slot(m, vr[i]) = value[i];
        } else {
            fail(m, "fmi3SetFloat64: only force, and the parameters before initialization, can be set");
            return fmi3Error;
        }
    }
    return fmi3OK;
}

fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 t, fmi3Float64 h, fmi3Boolean no_prior, fmi3Boolean *event,
                      fmi3Boolean *terminate, fmi3Boolean *early, fmi3Float64 *last) {
    (void)no_prior;
    Model *m = c;
    if (!m || !m->initialized || !(h > 0)) return fmi3Error;
    *event = false; *terminate = false; *early = false;
    double end = t + h;
    int returning_early = m->early_at > t && m->early_at < end - 1e-12;
    if (returning_early) end = m->early_at;
    long n = (long)((end - t) / SOLVER_STEP + 0.5);
    double stiffness = m->k * (double)m->gear, force = m->force * m->gain + m->kick;
    for (long k = 0; k < n; k++) {
        m->v += SOLVER_STEP * (force - stiffness * m->x);
        m->x += SOLVER_STEP * m->v;
    }
    m->ticks += n;
    m->steps += 1;
    m->kicks_seen += m->kick;
    m->time = end;
    *last = end;
    if (returning_early) *early = true;
    if (end >= m->stop_at - 1e-12) *terminate = true;
    return fmi3OK;
}


#define CHECK(n, nv) if (!m || (nv) != (n) || ((n) && (!vr || !value))) return fmi3Error
fmi3Status fmi3GetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t n, int32_t value[], size_t nv) {
    Model *m = c; CHECK(n, nv);
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == VR_STEPS) value[i] = m->steps;
        else if (vr[i] == VR_BLOB_IN_LENGTH) value[i] = (int32_t)m->blob_in_size;
        else if (vr[i] == VR_BLOB_IN_FIRST) value[i] = m->blob_in_size ? m->blob_in[0] : -1;
        else if (vr[i] == VR_KICKS) value[i] = m->kicks_seen;
        else if (vr[i] == VR_KICK) value[i] = m->kick;
        else { fail(m, "fmi3GetInt32: not an Int32 variable"); return fmi3Error; }
    }
    return fmi3OK;
}
fmi3Status fmi3SetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const int32_t value[], size_t nv) {
    Model *m = c; CHECK(n, nv);
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == VR_KICK) m->kick = value[i];
        else { fail(m, "fmi3SetInt32: only kick can be set"); return fmi3Error; }
    }
    return fmi3OK;
}

fmi3Status fmi3GetInt8(fmi3Instance c, const fmi3ValueReference vr[], size_t n, int8_t value[], size_t nv) {
    Model *m = c; CHECK(n, nv);
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == VR_WAVE8) value[i] = (int8_t)(m->steps % 200 - 100);
        else { fail(m, "fmi3GetInt8: not an Int8 variable"); return fmi3Error; }
    }
    return fmi3OK;
}
fmi3Status fmi3GetUInt16(fmi3Instance c, const fmi3ValueReference vr[], size_t n, uint16_t value[], size_t nv) {
    Model *m = c; CHECK(n, nv);
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == VR_COUNT16) value[i] = (uint16_t)((uint32_t)m->steps * 1000u);
        else { fail(m, "fmi3GetUInt16: not a UInt16 variable"); return fmi3Error; }
    }
    return fmi3OK;
}
fmi3Status fmi3GetInt16(fmi3Instance c, const fmi3ValueReference vr[], size_t n, int16_t value[], size_t nv) {
    Model *m = c; CHECK(n, nv);
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == VR_WAVE16) value[i] = (int16_t)(300 * (m->steps % 200) - 30000);
        else { fail(m, "fmi3GetInt16: not an Int16 variable"); return fmi3Error; }
    }
    return fmi3OK;
}
fmi3Status fmi3GetUInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t n, uint32_t value[], size_t nv) {
    Model *m = c; CHECK(n, nv);
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == VR_COUNT32) value[i] = (uint32_t)((uint64_t)m->steps * 40000000u);
        else { fail(m, "fmi3GetUInt32: not a UInt32 variable"); return fmi3Error; }
    }
    return fmi3OK;
}

fmi3Status fmi3GetInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, int64_t value[], size_t nv) {
    Model *m = c; CHECK(n, nv);
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == VR_TICKS) value[i] = m->ticks;
        else if (vr[i] == VR_GEAR) value[i] = m->gear;
        else { fail(m, "fmi3GetInt64: not an Int64 or Enumeration variable"); return fmi3Error; }
    }
    return fmi3OK;
}
fmi3Status fmi3SetInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const int64_t value[], size_t nv) {
    Model *m = c; CHECK(n, nv);
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == VR_GEAR && !m->initialized && (value[i] == 1 || value[i] == 2)) m->gear = value[i];
        else { fail(m, "fmi3SetInt64: gear (1 or 2) can be set before initialization"); return fmi3Error; }
    }
    return fmi3OK;
}
fmi3Status fmi3GetUInt8(fmi3Instance c, const fmi3ValueReference vr[], size_t n, uint8_t value[], size_t nv) {
    Model *m = c; CHECK(n, nv);
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == VR_GAIN) value[i] = m->gain;
        else { fail(m, "fmi3GetUInt8: not a UInt8 variable"); return fmi3Error; }
    }
    return fmi3OK;
}
fmi3Status fmi3SetUInt8(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const uint8_t value[], size_t nv) {
    Model *m = c; CHECK(n, nv);
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == VR_GAIN && !m->initialized) m->gain = value[i];
        else { fail(m, "fmi3SetUInt8: gain can be set before initialization"); return fmi3Error; }
    }
    return fmi3OK;
}
fmi3Status fmi3GetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t n, bool value[], size_t nv) {
    Model *m = c; CHECK(n, nv);
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == VR_MOVING) value[i] = fabs(m->v) > 0.5;
        else { fail(m, "fmi3GetBoolean: not a Boolean variable"); return fmi3Error; }
    }
    return fmi3OK;
}
fmi3Status fmi3GetFloat32(fmi3Instance c, const fmi3ValueReference vr[], size_t n, float value[], size_t nv) {
    Model *m = c; CHECK(n, nv);
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == VR_X32) value[i] = (float)m->x;
        else { fail(m, "fmi3GetFloat32: not a Float32 variable"); return fmi3Error; }
    }
    return fmi3OK;
}
fmi3Status fmi3GetString(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3String value[], size_t nv) {
    Model *m = c; CHECK(n, nv);
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == VR_LABEL || vr[i] == VR_LABEL_OUT) value[i] = m->label;
        else { fail(m, "fmi3GetString: not a String variable"); return fmi3Error; }
    }
    return fmi3OK;
}
fmi3Status fmi3SetString(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3String value[], size_t nv) {
    Model *m = c; CHECK(n, nv);
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == VR_LABEL && !m->initialized && value[i] && strlen(value[i]) < sizeof m->label) strcpy(m->label, value[i]);
        else { fail(m, "fmi3SetString: label (under 64 bytes) can be set before initialization"); return fmi3Error; }
    }
    return fmi3OK;
}


typedef uint8_t fmi3Byte;
fmi3Status fmi3GetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t n, size_t sizes[],
                         const fmi3Byte *value[], size_t nv) {
    Model *m = c;
    if (!m || nv != n || (n && (!vr || !value || !sizes))) return fmi3Error;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == VR_BLOB || vr[i] == VR_BLOB_OUT) { value[i] = m->blob; sizes[i] = m->blob_size; }
        else { fail(m, "fmi3GetBinary: not a Binary output"); return fmi3Error; }
    }
    return fmi3OK;
}
fmi3Status fmi3SetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const size_t sizes[],
                         const fmi3Byte *const value[], size_t nv) {
    Model *m = c;
    if (!m || nv != n || (n && (!vr || !value || !sizes))) return fmi3Error;
    for (size_t i = 0; i < n; i++) {
        if (sizes[i] > MAX_BLOB || (sizes[i] && !value[i])) { fail(m, "fmi3SetBinary: at most 64 bytes"); return fmi3Error; }
        if (vr[i] == VR_BLOB && !m->initialized) { memcpy(m->blob, value[i], sizes[i]); m->blob_size = sizes[i]; }
        else if (vr[i] == VR_BLOB_IN) { memcpy(m->blob_in, value[i], sizes[i]); m->blob_in_size = sizes[i]; }
        else { fail(m, "fmi3SetBinary: blob before initialization, or blob_in"); return fmi3Error; }
    }
    return fmi3OK;
}

typedef struct { Model model; } State;
fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState *s) {
    if (!c || !s) return fmi3Error;
    if (!*s) *s = malloc(sizeof(State));
    if (!*s) return fmi3Error;
    ((State *)*s)->model = *(Model *)c;
    return fmi3OK;
}
fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState s) {
    if (!c || !s) return fmi3Error;
    *(Model *)c = ((State *)s)->model;
    return fmi3OK;
}
fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState *s) {
    (void)c;
    if (s && *s) { free(*s); *s = NULL; }
    return fmi3OK;
}

/* The rest of fmi3Functions.h: not supported, answered with fmi3Error (argument lists are not
 * read, so they are declared without parameters). */
#define UNSUPPORTED(name) fmi3Status name() { return fmi3Error; }
UNSUPPORTED(fmi3EnterEventMode) 


UNSUPPORTED(fmi3GetClock) UNSUPPORTED(fmi3SetFloat32) UNSUPPORTED(fmi3SetInt8)
UNSUPPORTED(fmi3SetInt16) UNSUPPORTED(fmi3SetUInt16) 
UNSUPPORTED(fmi3SetUInt32) UNSUPPORTED(fmi3SetBoolean)
UNSUPPORTED(fmi3SetClock)
UNSUPPORTED(fmi3GetNumberOfVariableDependencies) UNSUPPORTED(fmi3GetVariableDependencies)
UNSUPPORTED(fmi3SerializedFMUStateSize) UNSUPPORTED(fmi3SerializeFMUState) UNSUPPORTED(fmi3DeserializeFMUState)
UNSUPPORTED(fmi3GetDirectionalDerivative) UNSUPPORTED(fmi3GetAdjointDerivative)

UNSUPPORTED(fmi3GetIntervalDecimal) UNSUPPORTED(fmi3GetIntervalFraction) UNSUPPORTED(fmi3GetShiftDecimal)
UNSUPPORTED(fmi3GetShiftFraction) UNSUPPORTED(fmi3SetIntervalDecimal) UNSUPPORTED(fmi3SetIntervalFraction)
UNSUPPORTED(fmi3SetShiftDecimal) UNSUPPORTED(fmi3SetShiftFraction) UNSUPPORTED(fmi3EvaluateDiscreteStates)
UNSUPPORTED(fmi3UpdateDiscreteStates) UNSUPPORTED(fmi3EnterContinuousTimeMode)
UNSUPPORTED(fmi3CompletedIntegratorStep) UNSUPPORTED(fmi3SetTime) UNSUPPORTED(fmi3SetContinuousStates)
UNSUPPORTED(fmi3GetContinuousStateDerivatives) UNSUPPORTED(fmi3GetEventIndicators)
UNSUPPORTED(fmi3GetContinuousStates) UNSUPPORTED(fmi3GetNominalsOfContinuousStates)
UNSUPPORTED(fmi3GetNumberOfEventIndicators) UNSUPPORTED(fmi3GetNumberOfContinuousStates)
UNSUPPORTED(fmi3GetOutputDerivatives) UNSUPPORTED(fmi3ActivateModelPartition)

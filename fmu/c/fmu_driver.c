/*
 * A plain C importer of the FMUs of this wrapper, for the memory check, the
 * cross-platform runs (wine, qemu-user) and the benchmark (not part of any FMU).
 * It loads an FMU binary (dlopen, or LoadLibrary on Windows) and either
 *
 *   soak  LIB GUID NX REPEATS VR_IN...   instantiates, simulates and frees Co-Simulation and
 *                                        Model Exchange instances REPEATS times, with FMU-state
 *                                        get/set/serialise/free, directional derivatives and a
 *                                        few rejected calls (run under valgrind); some FMU states
 *                                        are left for fmi2FreeInstance to free (FMI 2.0, 2.1.5), or
 *   bench LIB GUID NX STEPS VR_IN...     times fmi2DoStep at a 1 ms communication step, alone
 *                                        and with fmi2SetReal of the inputs before each step, or
 *   trace LIB GUID NX STEPS VR_IN...     prints the numbers of a run, %.17g, one line each:
 *                                        "cs K x..." after each of STEPS Co-Simulation steps, then
 *                                        "me der..." and "me dirder..." (d der(x) / d x[1]) of a Model
 *                                        Exchange instance
 *                                        (the numbers the cross-platform tests compare).
 *
 * The model's states have the value references 0..NX-1 (the table's layout).
 * Exit status 0 on success, 1 on any unexpected FMI status.
 */
#define _POSIX_C_SOURCE 200809L

#ifdef _WIN32
#include <windows.h>
#else
#include <dlfcn.h>
#endif
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fmi2Functions.h"

typedef struct {
    fmi2InstantiateTYPE *instantiate;
    fmi2FreeInstanceTYPE *free_instance;
    fmi2SetupExperimentTYPE *setup_experiment;
    fmi2EnterInitializationModeTYPE *enter_init;
    fmi2ExitInitializationModeTYPE *exit_init;
    fmi2TerminateTYPE *terminate;
    fmi2SetRealTYPE *set_real;
    fmi2GetRealTYPE *get_real;
    fmi2DoStepTYPE *do_step;
    fmi2GetFMUstateTYPE *get_state;
    fmi2SetFMUstateTYPE *set_state;
    fmi2FreeFMUstateTYPE *free_state;
    fmi2SerializedFMUstateSizeTYPE *serialized_size;
    fmi2SerializeFMUstateTYPE *serialize;
    fmi2DeSerializeFMUstateTYPE *deserialize;
    fmi2GetDirectionalDerivativeTYPE *directional;
    fmi2EnterContinuousTimeModeTYPE *enter_continuous;
    fmi2SetContinuousStatesTYPE *set_states;
    fmi2GetContinuousStatesTYPE *get_states;
    fmi2GetDerivativesTYPE *get_derivatives;
    fmi2SetTimeTYPE *set_time;
    fmi2ResetTYPE *reset;
} Api;

static int failures = 0;

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    (void)env;
    (void)name;
    (void)status;
    (void)category;
    (void)message;
}

/* The shared library: a HMODULE on Windows, a dlopen handle elsewhere. */
#ifdef _WIN32
typedef HMODULE Library;
static Library open_library(const char *path) { return LoadLibraryA(path); }
static void close_library(Library lib) { FreeLibrary(lib); }
static void report_open_error(void) { fprintf(stderr, "LoadLibrary: error %lu\n", (unsigned long)GetLastError()); }
static void *find_symbol(Library lib, const char *symbol) {
    FARPROC f = GetProcAddress(lib, symbol);
    void *p = NULL;
    memcpy(&p, &f, sizeof(p));
    return p;
}
#else
typedef void *Library;
static Library open_library(const char *path) { return dlopen(path, RTLD_NOW | RTLD_LOCAL); }
static void close_library(Library lib) { dlclose(lib); }
static void report_open_error(void) { fprintf(stderr, "dlopen: %s\n", dlerror()); }
static void *find_symbol(Library lib, const char *symbol) { return dlsym(lib, symbol); }
#endif

static void *load(Library lib, const char *symbol) {
    void *f = find_symbol(lib, symbol);
    if (f == NULL) fprintf(stderr, "missing symbol %s\n", symbol);
    return f;
}

static int load_api(Library lib, Api *api) {
    /* an object pointer converts to a function pointer through memcpy (POSIX dlsym; C99 has no cast) */
#define LOAD(field, name)                            \
    do {                                             \
        void *p_ = load(lib, name);                  \
        if (p_ == NULL) return -1;                   \
        memcpy(&api->field, &p_, sizeof(p_));        \
    } while (0)
    LOAD(instantiate, "fmi2Instantiate");
    LOAD(free_instance, "fmi2FreeInstance");
    LOAD(setup_experiment, "fmi2SetupExperiment");
    LOAD(enter_init, "fmi2EnterInitializationMode");
    LOAD(exit_init, "fmi2ExitInitializationMode");
    LOAD(terminate, "fmi2Terminate");
    LOAD(set_real, "fmi2SetReal");
    LOAD(get_real, "fmi2GetReal");
    LOAD(do_step, "fmi2DoStep");
    LOAD(get_state, "fmi2GetFMUstate");
    LOAD(set_state, "fmi2SetFMUstate");
    LOAD(free_state, "fmi2FreeFMUstate");
    LOAD(serialized_size, "fmi2SerializedFMUstateSize");
    LOAD(serialize, "fmi2SerializeFMUstate");
    LOAD(deserialize, "fmi2DeSerializeFMUstate");
    LOAD(directional, "fmi2GetDirectionalDerivative");
    LOAD(enter_continuous, "fmi2EnterContinuousTimeMode");
    LOAD(set_states, "fmi2SetContinuousStates");
    LOAD(get_states, "fmi2GetContinuousStates");
    LOAD(get_derivatives, "fmi2GetDerivatives");
    LOAD(set_time, "fmi2SetTime");
    LOAD(reset, "fmi2Reset");
#undef LOAD
    return 0;
}

static void expect(fmi2Status got, fmi2Status wanted, const char *what) {
    if (got != wanted) {
        fprintf(stderr, "%s: status %d, expected %d\n", what, (int)got, (int)wanted);
        failures++;
    }
}

static fmi2Component start(const Api *api, const fmi2CallbackFunctions *cb, const char *guid, fmi2Type type) {
    fmi2Component c = api->instantiate("driver", type, guid, "", cb, fmi2False, fmi2False);
    if (c == NULL) {
        fprintf(stderr, "fmi2Instantiate failed\n");
        failures++;
        return NULL;
    }
    expect(api->setup_experiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK, "fmi2SetupExperiment");
    expect(api->enter_init(c), fmi2OK, "fmi2EnterInitializationMode");
    expect(api->exit_init(c), fmi2OK, "fmi2ExitInitializationMode");
    return c;
}

/* A small, smooth torque: the same sequence in every run. */
static void inputs_at(double t, size_t n_in, double *u) {
    size_t i;
    for (i = 0; i < n_in; i++) u[i] = 1e-3 * sin(3.0 * t + (double)i);
}

static void run_cs(const Api *api, const fmi2CallbackFunctions *cb, const char *guid, size_t nx,
                   const fmi2ValueReference *vr_in, size_t n_in) {
    const double h = 1e-3;
    double *u = (double *)calloc(n_in > 0 ? n_in : 1, sizeof(double));
    double *x = (double *)calloc(nx > 0 ? nx : 1, sizeof(double));
    fmi2ValueReference *vr_x = (fmi2ValueReference *)calloc(nx > 0 ? nx : 1, sizeof(fmi2ValueReference));
    fmi2FMUstate state = NULL, copy = NULL;
    fmi2Byte *bytes = NULL;
    size_t size = 0, i;
    long k;
    fmi2Component c;

    if (u == NULL || x == NULL || vr_x == NULL) {
        failures++;
        goto done;
    }
    for (i = 0; i < nx; i++) vr_x[i] = (fmi2ValueReference)i;
    c = start(api, cb, guid, fmi2CoSimulation);
    if (c == NULL) goto done;
    for (k = 0; k < 200; k++) {
        double t = (double)k * h;
        inputs_at(t, n_in, u);
        expect(api->set_real(c, vr_in, n_in, u), fmi2OK, "fmi2SetReal");
        expect(api->do_step(c, t, h, fmi2True), fmi2OK, "fmi2DoStep");
        expect(api->get_real(c, vr_x, nx, x), fmi2OK, "fmi2GetReal");
    }
    expect(api->get_state(c, &state), fmi2OK, "fmi2GetFMUstate");
    expect(api->serialized_size(c, state, &size), fmi2OK, "fmi2SerializedFMUstateSize");
    bytes = (fmi2Byte *)malloc(size);
    if (bytes == NULL) {
        failures++;
    } else {
        expect(api->serialize(c, state, bytes, size), fmi2OK, "fmi2SerializeFMUstate");
        expect(api->deserialize(c, bytes, size, &copy), fmi2OK, "fmi2DeSerializeFMUstate");
        /* a buffer one byte short is rejected and allocates nothing */
        {
            fmi2FMUstate rejected = NULL;
            expect(api->deserialize(c, bytes, size - 1, &rejected), fmi2Error, "short fmi2DeSerializeFMUstate");
            if (rejected != NULL) failures++;
        }
        expect(api->set_state(c, copy), fmi2OK, "fmi2SetFMUstate (deserialised)");
    }
    for (k = 200; k < 250; k++) {
        double t = (double)k * h;
        inputs_at(t, n_in, u);
        expect(api->set_real(c, vr_in, n_in, u), fmi2OK, "fmi2SetReal");
        expect(api->do_step(c, t, h, fmi2True), fmi2OK, "fmi2DoStep");
    }
    expect(api->set_state(c, state), fmi2OK, "fmi2SetFMUstate");
    /* a state that becomes non-finite: fmi2Discard, then back to the saved state */
    if (n_in > 0) {
        double huge[64];
        for (i = 0; i < n_in && i < 64; i++) huge[i] = 1e308;
        expect(api->set_real(c, vr_in, n_in < 64 ? n_in : 64, huge), fmi2OK, "fmi2SetReal (huge)");
        expect(api->do_step(c, 0.2, h, fmi2True), fmi2Discard, "fmi2DoStep (non-finite)");
        expect(api->set_state(c, state), fmi2OK, "fmi2SetFMUstate after discard");
    }
    expect(api->free_state(c, &state), fmi2OK, "fmi2FreeFMUstate");
    expect(api->free_state(c, &copy), fmi2OK, "fmi2FreeFMUstate (copy)");
    {
        /* two FMU states never freed by the importer: fmi2FreeInstance frees them */
        fmi2FMUstate left = NULL, left_copy = NULL;
        expect(api->get_state(c, &left), fmi2OK, "fmi2GetFMUstate (left to fmi2FreeInstance)");
        if (bytes != NULL)
            expect(api->deserialize(c, bytes, size, &left_copy), fmi2OK, "fmi2DeSerializeFMUstate (left)");
    }
    expect(api->terminate(c), fmi2OK, "fmi2Terminate");
    /* a call out of order: rejected, then the instance is reset and freed */
    expect(api->do_step(c, 0.0, h, fmi2True), fmi2Error, "fmi2DoStep after fmi2Terminate");
    expect(api->reset(c), fmi2OK, "fmi2Reset");
    api->free_instance(c);
done:
    free(bytes);
    free(vr_x);
    free(x);
    free(u);
}

static void run_me(const Api *api, const fmi2CallbackFunctions *cb, const char *guid, size_t nx) {
    double *x = (double *)calloc(nx > 0 ? nx : 1, sizeof(double));
    double *dx = (double *)calloc(nx > 0 ? nx : 1, sizeof(double));
    fmi2ValueReference vr_known = 0, vr_unknown = (fmi2ValueReference)nx; /* x[0] and der(x[0]) */
    double seed = 1.0, sens = 0.0;
    fmi2FMUstate state = NULL;
    size_t i;
    fmi2Component c;

    if (x == NULL || dx == NULL) {
        failures++;
        goto done;
    }
    c = start(api, cb, guid, fmi2ModelExchange);
    if (c == NULL) goto done;
    expect(api->enter_continuous(c), fmi2OK, "fmi2EnterContinuousTimeMode");
    expect(api->get_states(c, x, nx), fmi2OK, "fmi2GetContinuousStates");
    for (i = 0; i < nx; i++) x[i] += 0.01 * (double)(i + 1);
    expect(api->set_time(c, 0.5), fmi2OK, "fmi2SetTime");
    expect(api->set_states(c, x, nx), fmi2OK, "fmi2SetContinuousStates");
    expect(api->get_derivatives(c, dx, nx), fmi2OK, "fmi2GetDerivatives");
    expect(api->directional(c, &vr_unknown, 1, &vr_known, 1, &seed, &sens), fmi2OK, "fmi2GetDirectionalDerivative");
    expect(api->get_state(c, &state), fmi2OK, "fmi2GetFMUstate (ME)");
    expect(api->set_state(c, state), fmi2OK, "fmi2SetFMUstate (ME)");
    expect(api->free_state(c, &state), fmi2OK, "fmi2FreeFMUstate (ME)");
    expect(api->get_state(c, &state), fmi2OK, "fmi2GetFMUstate (ME, left to fmi2FreeInstance)");
    expect(api->terminate(c), fmi2OK, "fmi2Terminate (ME)");
    api->free_instance(c);
done:
    free(dx);
    free(x);
}

static double now(void) {
#ifdef _WIN32
    LARGE_INTEGER count, frequency;
    QueryPerformanceCounter(&count);
    QueryPerformanceFrequency(&frequency);
    return (double)count.QuadPart / (double)frequency.QuadPart;
#else
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
#endif
}

static void print_row(const char *label, const double *v, size_t n) {
    size_t i;
    printf("%s", label);
    for (i = 0; i < n; i++) printf(" %.17g", v[i]);
    printf("\n");
}

/* The numbers of one run: states after each Co-Simulation step, then ME derivatives. */
static void trace(const Api *api, const fmi2CallbackFunctions *cb, const char *guid, size_t nx, long steps,
                  const fmi2ValueReference *vr_in, size_t n_in) {
    const double h = 1e-3;
    double u[64] = {0.0}, x[64] = {0.0}, dx[64] = {0.0};
    fmi2ValueReference vr_x[64], vr_der[64], vr_known;
    double seed = 1.0, sens[64] = {0.0};
    char label[32];
    size_t i;
    long k;
    fmi2Component c;

    if (nx > 64 || n_in > 64) {
        fprintf(stderr, "trace: at most 64 states and inputs\n");
        failures++;
        return;
    }
    for (i = 0; i < nx; i++) {
        vr_x[i] = (fmi2ValueReference)i;
        vr_der[i] = (fmi2ValueReference)(nx + i);
    }
    vr_known = nx > 1 ? 1 : 0; /* the derivatives' sensitivity to the second state (q[1] of a robot) */
    c = start(api, cb, guid, fmi2CoSimulation);
    if (c == NULL) return;
    for (k = 0; k < steps; k++) {
        double t = (double)k * h;
        inputs_at(t, n_in, u);
        expect(api->set_real(c, vr_in, n_in, u), fmi2OK, "fmi2SetReal");
        expect(api->do_step(c, t, h, fmi2True), fmi2OK, "fmi2DoStep");
        expect(api->get_real(c, vr_x, nx, x), fmi2OK, "fmi2GetReal");
        snprintf(label, sizeof(label), "cs %ld", k + 1);
        print_row(label, x, nx);
    }
    api->free_instance(c);
    c = start(api, cb, guid, fmi2ModelExchange);
    if (c == NULL) return;
    expect(api->enter_continuous(c), fmi2OK, "fmi2EnterContinuousTimeMode");
    for (i = 0; i < nx; i++) x[i] = 0.1 * (double)(i + 1);
    inputs_at(0.25, n_in, u);
    expect(api->set_real(c, vr_in, n_in, u), fmi2OK, "fmi2SetReal (ME)");
    expect(api->set_states(c, x, nx), fmi2OK, "fmi2SetContinuousStates");
    expect(api->get_derivatives(c, dx, nx), fmi2OK, "fmi2GetDerivatives");
    print_row("me der", dx, nx);
    expect(api->directional(c, vr_der, nx, &vr_known, 1, &seed, sens), fmi2OK, "fmi2GetDirectionalDerivative");
    print_row("me dirder", sens, nx);
    expect(api->terminate(c), fmi2OK, "fmi2Terminate (ME)");
    api->free_instance(c);
}

static void bench(const Api *api, const fmi2CallbackFunctions *cb, const char *guid, long steps,
                  const fmi2ValueReference *vr_in, size_t n_in) {
    const double h = 1e-3;
    double u[64] = {0.0};
    double t0, t1, t2;
    long k;
    fmi2Component c = start(api, cb, guid, fmi2CoSimulation);
    if (c == NULL || n_in > 64) {
        failures++;
        if (c != NULL) api->free_instance(c);
        return;
    }
    t0 = now();
    for (k = 0; k < steps; k++) {
        if (api->do_step(c, (double)k * h, h, fmi2True) != fmi2OK) failures++;
    }
    t1 = now();
    for (k = steps; k < 2 * steps; k++) {
        u[0] = 1e-4 * (double)(k & 7);
        if (api->set_real(c, vr_in, n_in, u) != fmi2OK) failures++;
        if (api->do_step(c, (double)k * h, h, fmi2True) != fmi2OK) failures++;
    }
    t2 = now();
    printf("doStep_us %.6f\nsetReal_doStep_us %.6f\n", 1e6 * (t1 - t0) / (double)steps,
           1e6 * (t2 - t1) / (double)steps);
    api->free_instance(c);
}

int main(int argc, char **argv) {
    Api api;
    Library lib;
    fmi2CallbackFunctions cb;
    fmi2ValueReference vr_in[64];
    size_t n_in = 0, nx;
    long count, r;
    int i;

    if (argc < 5 || (strcmp(argv[1], "soak") != 0 && strcmp(argv[1], "bench") != 0 && strcmp(argv[1], "trace") != 0)) {
        fprintf(stderr, "usage: %s soak|bench|trace LIB GUID NX COUNT [VR_IN...]\n", argv[0]);
        return 2;
    }
    nx = (size_t)strtoul(argv[4], NULL, 10);
    count = argc > 5 ? strtol(argv[5], NULL, 10) : 1;
    for (i = 6; i < argc && n_in < 64; i++) vr_in[n_in++] = (fmi2ValueReference)strtoul(argv[i], NULL, 10);

    lib = open_library(argv[2]);
    if (lib == NULL) {
        report_open_error();
        return 1;
    }
    if (load_api(lib, &api) != 0) {
        close_library(lib);
        return 1;
    }
    cb.logger = logger;
    cb.allocateMemory = calloc;
    cb.freeMemory = free;
    cb.stepFinished = NULL;
    cb.componentEnvironment = NULL;

    if (strcmp(argv[1], "soak") == 0) {
        for (r = 0; r < count; r++) {
            /* a wrong GUID is refused without allocating anything */
            if (api.instantiate("wrong", fmi2CoSimulation, "{not-this-model}", "", &cb, fmi2False, fmi2False) != NULL)
                failures++;
            run_cs(&api, &cb, argv[3], nx, vr_in, n_in);
            run_me(&api, &cb, argv[3], nx);
        }
        printf("soak: %ld repetitions, %d failures\n", count, failures);
    } else if (strcmp(argv[1], "trace") == 0) {
        trace(&api, &cb, argv[3], nx, count, vr_in, n_in);
    } else {
        bench(&api, &cb, argv[3], count, vr_in, n_in);
    }
    close_library(lib);
    return failures == 0 ? 0 : 1;
}

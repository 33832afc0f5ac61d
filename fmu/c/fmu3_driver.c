/*
 * A plain C importer of the FMI 3.0 FMUs of this wrapper, for the memory check (not part of any FMU).
 * It dlopens an FMU binary and
 *
 *   soak LIB TOKEN NX REPEATS VR_Q VR_QD VR_TAU VR_DERQ NU   instantiates, simulates and frees a
 *        Co-Simulation and a Model Exchange instance REPEATS times: steps with fmi3SetFloat64 of the
 *        torques, FMU state get/serialise/deserialise/set/free, a corrupted serialised state, a wrong
 *        nValues, a call out of order, reset; ME: states, derivatives, directional and adjoint
 *        derivatives, event indicators. Some FMU states are left for fmi3FreeInstance to free.
 *
 * Exit status 0 on success, 1 on any unexpected FMI status.
 */
#define _POSIX_C_SOURCE 200809L

#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"

static int failures = 0;

static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    (void)env;
    (void)status;
    (void)category;
    (void)message;
}

#define LOAD(name) name##TYPE *name = (name##TYPE *)dlsym(lib, #name)
#define EXPECT(call, want)                                                                    \
    do {                                                                                      \
        int got_ = (int)(call);                                                               \
        if (got_ != (want)) {                                                                 \
            fprintf(stderr, "line %d: %s returned %d, expected %d\n", __LINE__, #call, got_, want); \
            failures++;                                                                       \
        }                                                                                     \
    } while (0)

int main(int argc, char **argv) {
    void *lib;
    const char *token;
    size_t nx, nu, k;
    long repeats, r;
    fmi3ValueReference vr_q, vr_qd, vr_tau, vr_derq;
    if (argc != 11 || strcmp(argv[1], "soak") != 0) {
        fprintf(stderr, "usage: %s soak LIB TOKEN NX REPEATS VR_Q VR_QD VR_TAU VR_DERQ NU\n", argv[0]);
        return 2;
    }
    lib = dlopen(argv[2], RTLD_NOW | RTLD_LOCAL);
    if (lib == NULL) {
        fprintf(stderr, "dlopen: %s\n", dlerror());
        return 2;
    }
    token = argv[3];
    nx = (size_t)strtoul(argv[4], NULL, 10);
    repeats = strtol(argv[5], NULL, 10);
    vr_q = (fmi3ValueReference)strtoul(argv[6], NULL, 10);
    vr_qd = (fmi3ValueReference)strtoul(argv[7], NULL, 10);
    vr_tau = (fmi3ValueReference)strtoul(argv[8], NULL, 10);
    vr_derq = (fmi3ValueReference)strtoul(argv[9], NULL, 10);
    nu = (size_t)strtoul(argv[10], NULL, 10);
    {
        LOAD(fmi3InstantiateCoSimulation);
        LOAD(fmi3InstantiateModelExchange);
        LOAD(fmi3FreeInstance);
        LOAD(fmi3EnterInitializationMode);
        LOAD(fmi3ExitInitializationMode);
        LOAD(fmi3Terminate);
        LOAD(fmi3Reset);
        LOAD(fmi3SetFloat64);
        LOAD(fmi3GetFloat64);
        LOAD(fmi3DoStep);
        LOAD(fmi3GetFMUState);
        LOAD(fmi3SetFMUState);
        LOAD(fmi3FreeFMUState);
        LOAD(fmi3SerializedFMUStateSize);
        LOAD(fmi3SerializeFMUState);
        LOAD(fmi3DeserializeFMUState);
        LOAD(fmi3GetDirectionalDerivative);
        LOAD(fmi3GetAdjointDerivative);
        LOAD(fmi3UpdateDiscreteStates);
        LOAD(fmi3EnterContinuousTimeMode);
        LOAD(fmi3SetContinuousStates);
        LOAD(fmi3GetContinuousStates);
        LOAD(fmi3GetContinuousStateDerivatives);
        LOAD(fmi3GetEventIndicators);
        LOAD(fmi3GetNumberOfEventIndicators);
        LOAD(fmi3SetTime);
        double *x = (double *)calloc(nx, sizeof(double)), *dx = (double *)calloc(nx, sizeof(double));
        double *u = (double *)calloc(nu, sizeof(double)), *seed = (double *)calloc(nx + nu, sizeof(double));
        double *sens = (double *)calloc(nx + nu, sizeof(double)), *z = NULL;
        if (fmi3InstantiateCoSimulation == NULL || fmi3GetAdjointDerivative == NULL || fmi3SetTime == NULL ||
            x == NULL || dx == NULL || u == NULL || seed == NULL || sens == NULL) {
            fprintf(stderr, "missing FMI 3.0 functions or memory\n");
            return 2;
        }
        for (r = 0; r < repeats; r++) {
            fmi3Instance cs, me;
            fmi3FMUState s1 = NULL, s2 = NULL, kept = NULL;
            fmi3Boolean ev, term, early, b[6];
            fmi3Float64 last, t = 0.0, next_time;
            size_t size = 0, nz = 0;
            unsigned char *blob;
            fmi3ValueReference xs[2], known[3];
            xs[0] = vr_q;
            xs[1] = vr_qd;
            /* refused: a wrong token, and event mode in Co-Simulation */
            if (fmi3InstantiateCoSimulation("bad", "{wrong}", "", fmi3False, fmi3False, fmi3False, fmi3False, NULL, 0,
                                            NULL, logger, NULL) != NULL)
                failures++;
            if (fmi3InstantiateCoSimulation("bad", token, "", fmi3False, fmi3False, fmi3True, fmi3False, NULL, 0, NULL,
                                            logger, NULL) != NULL)
                failures++;

            cs = fmi3InstantiateCoSimulation("cs", token, "", fmi3False, fmi3False, fmi3False, fmi3False, NULL, 0, NULL,
                                             logger, NULL);
            if (cs == NULL) {
                failures++;
                continue;
            }
            EXPECT(fmi3DoStep(cs, 0.0, 1e-3, fmi3True, &ev, &term, &early, &last), fmi3Error); /* out of order */
            EXPECT(fmi3Reset(cs), fmi3OK);
            EXPECT(fmi3EnterInitializationMode(cs, fmi3False, 0.0, 0.0, fmi3False, 0.0), fmi3OK);
            EXPECT(fmi3ExitInitializationMode(cs), fmi3OK);
            for (k = 0; k < 250; k++) {
                size_t i;
                for (i = 0; i < nu; i++) u[i] = 0.1 * (double)((k + i) % 7) - 0.3;
                EXPECT(fmi3SetFloat64(cs, &vr_tau, 1, u, nu), fmi3OK);
                EXPECT(fmi3DoStep(cs, t, 1e-3, fmi3True, &ev, &term, &early, &last), fmi3OK);
                t += 1e-3;
                if (k == 100) EXPECT(fmi3GetFMUState(cs, &s1), fmi3OK);
            }
            EXPECT(fmi3GetFloat64(cs, xs, 2, x, nx), fmi3OK);
            EXPECT(fmi3GetFloat64(cs, xs, 2, x, nx - 1), fmi3Error); /* wrong nValues */
            EXPECT(fmi3SerializedFMUStateSize(cs, s1, &size), fmi3OK);
            blob = (unsigned char *)malloc(size);
            EXPECT(fmi3SerializeFMUState(cs, s1, blob, size), fmi3OK);
            EXPECT(fmi3SerializeFMUState(cs, s1, blob, size - 1), fmi3Error); /* short buffer */
            EXPECT(fmi3DeserializeFMUState(cs, blob, size, &s2), fmi3OK);
            EXPECT(fmi3SetFMUState(cs, s2), fmi3OK);
            blob[0] ^= 1u;
            EXPECT(fmi3DeserializeFMUState(cs, blob, size, &kept), fmi3Error); /* corrupted */
            free(blob);
            EXPECT(fmi3SetFMUState(cs, s1), fmi3OK);
            EXPECT(fmi3FreeFMUState(cs, &s2), fmi3OK);
            EXPECT(fmi3GetFMUState(cs, &kept), fmi3OK); /* left for fmi3FreeInstance */
            EXPECT(fmi3Terminate(cs), fmi3OK);
            fmi3FreeInstance(cs);

            me = fmi3InstantiateModelExchange("me", token, "", fmi3False, fmi3False, NULL, logger);
            if (me == NULL) {
                failures++;
                continue;
            }
            EXPECT(fmi3EnterInitializationMode(me, fmi3False, 0.0, 0.0, fmi3False, 0.0), fmi3OK);
            EXPECT(fmi3ExitInitializationMode(me), fmi3OK);
            EXPECT(fmi3UpdateDiscreteStates(me, &b[0], &b[1], &b[2], &b[3], &b[4], &next_time), fmi3OK);
            EXPECT(fmi3EnterContinuousTimeMode(me), fmi3OK);
            EXPECT(fmi3GetContinuousStates(me, x, nx), fmi3OK);
            x[0] += 0.1;
            EXPECT(fmi3SetTime(me, 0.01), fmi3OK);
            EXPECT(fmi3SetContinuousStates(me, x, nx), fmi3OK);
            EXPECT(fmi3GetContinuousStateDerivatives(me, dx, nx), fmi3OK);
            EXPECT(fmi3GetNumberOfEventIndicators(me, &nz), fmi3OK);
            z = (double *)calloc(nz > 0 ? nz : 1, sizeof(double));
            EXPECT(fmi3GetEventIndicators(me, z, nz), fmi3OK);
            free(z);
            known[0] = vr_q;
            known[1] = vr_qd;
            known[2] = vr_tau;
            memset(seed, 0, (nx + nu) * sizeof(double));
            seed[1] = 1.0;
            EXPECT(fmi3GetDirectionalDerivative(me, &vr_derq, 1, known, 3, seed, nx + nu, sens, nx / 2), fmi3OK);
            EXPECT(fmi3GetAdjointDerivative(me, &vr_derq, 1, known, 3, seed, nx / 2, sens, nx + nu), fmi3OK);
            EXPECT(fmi3GetAdjointDerivative(me, &vr_derq, 1, known, 3, seed, nx, sens, nx + nu), fmi3Error);
            s1 = NULL;
            EXPECT(fmi3GetFMUState(me, &s1), fmi3OK); /* left for fmi3FreeInstance */
            fmi3FreeInstance(me);
        }
        printf("soak: %ld repetitions, %d failures\n", repeats, failures);
        free(x);
        free(dx);
        free(u);
        free(seed);
        free(sens);
    }
    dlclose(lib);
    return failures == 0 ? 0 : 1;
}

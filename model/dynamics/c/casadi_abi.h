/*
 * The C types of every CasADi-generated file of manipulator-workbench and of the
 * handwritten C that calls it (model/dynamics/c/batch.c, the FMU wrapper).
 *
 * model/codegen.py includes this header at the top of each generated file, before
 * CasADi's own fallback definitions, and passes the same choice to
 * casadi.CodeGenerator (CASADI_INT, CASADI_REAL); Python calls the compiled code
 * through ctypes.c_longlong and ctypes.c_double. The assertions below stop the
 * build if a platform or a future edit breaks that agreement. Handwritten, not
 * generated; shipped as package data and copied next to generated sources.
 */
#ifndef MW_CASADI_ABI_H
#define MW_CASADI_ABI_H

#define casadi_int long long int
#define casadi_real double

/* __extension__: no -Wpedantic warning for a C11 assertion in a C99 build (gcc and clang). */
#if defined(__GNUC__)
#define MW_EXTENSION __extension__
#else
#define MW_EXTENSION
#endif
MW_EXTENSION _Static_assert(sizeof(casadi_int) == 8, "casadi_int must be the 8-byte integer Python passes (ctypes.c_longlong)");
MW_EXTENSION _Static_assert(sizeof(casadi_real) == 8, "casadi_real must be the IEEE double Python passes (ctypes.c_double)");

#endif /* MW_CASADI_ABI_H */

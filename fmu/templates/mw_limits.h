/* generated, do not edit: rendered by fmu/limits.py from the constants of fmu/variables.py */
#ifndef MW_LIMITS_H
#define MW_LIMITS_H

/* Most RK4 sub-steps one DoStep may take: bounds the work (and the time) of one call (MAX_SUBSTEPS). */
#define MW_MAX_SUBSTEPS ${max_substeps}ull
/* Relative noise in communicationStepSize / internal_step forgiven when counting sub-steps (SUBSTEP_RTOL). */
#define MW_SUBSTEP_RTOL ${substep_rtol}

#endif /* MW_LIMITS_H */

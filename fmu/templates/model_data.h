/* generated, do not edit: rendered by fmu/variables.py from the FMU's variable table */
#ifndef MW_MODEL_DATA_H
#define MW_MODEL_DATA_H

#define MW_MODEL_IDENTIFIER $model_identifier_string
#define MW_GUID $guid

#define MW_NX $nx
#define MW_NU $nu
#define MW_NP $np
#define MW_NY $ny
#define MW_NZ $nz
#define MW_ND $nd
#define MW_NPIV $npiv
#define MW_NVARS $nvars
#define MW_NARRAYS $narrays

/* value references */
$value_references

#endif /* MW_MODEL_DATA_H */

/* generated, do not edit: rendered by fmu/variables.py from the FMU's variable table */
#include <math.h>
#include <stddef.h>

#include "model.h"
#include "model_data.h"
#include "$casadi_header"

/* one row per value reference: name, kind, settable, index, min, max */
static const MwVariable mw_variables[MW_NVARS] = {
$variable_rows
};

/* the FMI 3.0 variables: name, first row, number of rows, scalar (no <Dimension>) */
static const MwArray mw_arrays[MW_NARRAYS] = {
$array_rows
};

static const double mw_x_start[] = $x_start;
static const double mw_x_nominal[] = $x_nominal;
static const double mw_u_start[] = $u_start;
static const double mw_p_start[] = $p_start;
static const double mw_d_start[] = $d_start;

static const MwModel mw_model_data = {
    MW_MODEL_IDENTIFIER,
    MW_GUID,
    MW_NX, MW_NU, MW_NP, MW_NY,
    MW_NZ,
    MW_NVARS,
    mw_variables,
    MW_NARRAYS,
    mw_arrays,
    mw_x_start,
    mw_x_nominal,
    mw_u_start,
    mw_p_start,
    $step_start,
    MW_ND,
    $sample_period,
    mw_d_start,
    {$ode, ${ode}_work},
    {$ode_sliding, ${ode_sliding}_work},
    {$out, ${out}_work},
    {$ode_dir, ${ode_dir}_work},
    {$out_dir, ${out_dir}_work},
    {$ode_adj, ${ode_adj}_work},
    {$out_adj, ${out_adj}_work},
    {$tick, ${tick}_work},
    {$events, ${events}_work},
    {$events_sliding, ${events_sliding}_work},
    {$update, ${update}_work},
    {$start, ${start}_work},
    {$active, ${active}_work},
    MW_NPIV,
    {$pivots, ${pivots}_work},
};

const MwModel *mw_model(void) { return &mw_model_data; }

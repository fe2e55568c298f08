// The K&C sheet as files and text: kc.json (format "kcrig kc 1"), the
// gradients CSV that MATLAB's readtable and pandas' read_csv load as a
// table, and the sheet printed by `kcrig kc` and the campaign. Every file
// carries display units (mm, deg, per kN; the unit beside each value).
#ifndef KCRIG_KC_SHEET_KC_SHEET_IO_H_
#define KCRIG_KC_SHEET_KC_SHEET_IO_H_

#include <string>

#include "kc_sheet/kc_sheet.h"

namespace kcrig {

std::string KcSheetToJson(const KcSheet& sheet);

// One row per figure: log,phi_deg,z_a_m,channel,figure,unit,rig,
// rig_standard_error,rig_noise_standard_error,model,model_standard_error,
// z,differs. Figures per run and channel: gradient, rising_gradient,
// falling_gradient, loop_width, loop_area; then the named figures (log
// empty, channel the figure's place).
std::string KcSheetToCsv(const KcSheet& sheet);

// The sheet as a K&C engineer reads it: per run a table of the channels'
// gradients and loop widths (rig, model, difference in standard errors,
// "<<" where they differ), then the standard figures.
std::string KcSheetSummary(const KcSheet& sheet);

}  // namespace kcrig

#endif  // KCRIG_KC_SHEET_KC_SHEET_IO_H_

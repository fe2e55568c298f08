// A structural check of a level-5 MAT-file (MathWorks' published layout)
// before libmatio reads it: libmatio allocates what a file's headers
// declare, so a hostile file of a few bytes could make it allocate
// gigabytes. Every data element must lie within its container, a
// compressed element must inflate (within a budget) to the elements it
// declares, and an array's data must have the size its dimensions and type
// declare. Little-endian files only (what MATLAB, Octave and SciPy write on
// every current machine); the HDF5-based v7.3 format is refused with the
// advice to save as -v7.
#ifndef KCRIG_RECORDS_INTERNAL_MAT5_CHECK_H_
#define KCRIG_RECORDS_INTERNAL_MAT5_CHECK_H_

#include <cstddef>
#include <string>

#include "base/status.h"

namespace kcrig {

// `bytes` is the whole file named `path` (for errors); inflated data may
// total at most `inflate_budget` bytes.
Status CheckMat5Structure(const std::string& bytes, const std::string& path,
                          std::size_t inflate_budget);

}  // namespace kcrig

#endif  // KCRIG_RECORDS_INTERNAL_MAT5_CHECK_H_

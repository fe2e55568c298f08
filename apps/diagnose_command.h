// `kcrig diagnose`: the sim-to-real gap of run logs — whether there is one,
// where it lies, which unmodelled effect explains it and how far it shrinks.
#ifndef KCRIG_APPS_DIAGNOSE_COMMAND_H_
#define KCRIG_APPS_DIAGNOSE_COMMAND_H_

#include <functional>

#include "CLI/CLI.hpp"

namespace kcrig {

void AddDiagnoseCommand(CLI::App* app, std::function<int()>* run);

}  // namespace kcrig

#endif  // KCRIG_APPS_DIAGNOSE_COMMAND_H_

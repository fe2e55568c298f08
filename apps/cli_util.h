// Small parsing helpers shared by the subcommands.
#ifndef KCRIG_APPS_CLI_UTIL_H_
#define KCRIG_APPS_CLI_UTIL_H_

#include <string>
#include <vector>

#include "rt_core/status.h"

namespace kcrig {

// The whole text as a finite double.
bool ParseFiniteDouble(const std::string& text, double* value);

// "NAME=VALUE" with a finite VALUE; `option` names the flag in errors.
Status ParseAssignment(const std::string& option, const std::string& text,
                       std::string* name, double* value);

// "x,toe" -> channel indices into x, y, z, toe, camber, caster.
Status ParseChannels(const std::string& text, std::vector<int>* channels);

// "a,b,c" -> {"a", "b", "c"}; empty items are dropped.
std::vector<std::string> SplitList(const std::string& text);

}  // namespace kcrig

#endif  // KCRIG_APPS_CLI_UTIL_H_

// kcrig campaign: the two-level loop estimate -> design -> rig -> estimate.
#ifndef KCRIG_APPS_CAMPAIGN_COMMAND_H_
#define KCRIG_APPS_CAMPAIGN_COMMAND_H_

#include <functional>

#include "CLI/CLI.hpp"

namespace kcrig {

void AddCampaignCommand(CLI::App* app, std::function<int()>* run);

}  // namespace kcrig

#endif  // KCRIG_APPS_CAMPAIGN_COMMAND_H_

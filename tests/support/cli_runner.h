// Runs the real kcrig binary the way a user does and captures what it says.
#ifndef KCRIG_TESTS_SUPPORT_CLI_RUNNER_H_
#define KCRIG_TESTS_SUPPORT_CLI_RUNNER_H_

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <string>

namespace kcrig {

struct CliResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

// Runs a shell command line, capturing stdout and stderr.
inline CliResult RunCommand(const std::string& command_line) {
  const std::string command = command_line + " 2>&1";
  CliResult result;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return result;
  std::array<char, 4096> buffer;
  size_t n = 0;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) {
    result.output.append(buffer.data(), n);
  }
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

// `prefix` goes before the binary (e.g. "unshare --user ").
inline CliResult RunKcrig(const std::string& arguments,
                          const std::string& prefix = "") {
  return RunCommand(prefix + std::string(KCRIG_BINARY) + " " + arguments);
}

inline int CountLines(const std::string& text) {
  return static_cast<int>(std::count(text.begin(), text.end(), '\n'));
}

}  // namespace kcrig

#endif  // KCRIG_TESTS_SUPPORT_CLI_RUNNER_H_

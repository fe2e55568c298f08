// A real process started by a test (kcrig emulate, kcrig run, a peer), its
// stdout and stderr going to a file; killed and reaped when the object dies.
#ifndef KCRIG_TESTS_SUPPORT_CHILD_PROCESS_H_
#define KCRIG_TESTS_SUPPORT_CHILD_PROCESS_H_

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace kcrig {

class ChildProcess {
 public:
  // argv[0] is the program path; output goes to `output_path`.
  ChildProcess(const std::vector<std::string>& argv, std::string output_path)
      : output_path_(std::move(output_path)) {
    pid_ = fork();
    if (pid_ == 0) {
      const int fd =
          open(output_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      dup2(fd, 1);
      dup2(fd, 2);
      std::vector<char*> args;
      for (const std::string& a : argv)
        args.push_back(const_cast<char*>(a.c_str()));
      args.push_back(nullptr);
      execv(args[0], args.data());
      _exit(127);
    }
  }
  ~ChildProcess() {
    if (pid_ > 0 && !reaped_) {
      kill(pid_, SIGCONT);
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  pid_t pid() const { return pid_; }
  // The process' peak resident set [KiB], once Wait has reaped it.
  long peak_rss_kib() const { return peak_rss_kib_; }
  void Signal(int signal) const { kill(pid_, signal); }

  std::string Output() const {
    std::ifstream in(output_path_);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  }

  // Polls the output until `pattern` matches (first group returned) or
  // `timeout_s` passes ("" then).
  std::string WaitForOutput(const std::string& pattern,
                            double timeout_s = 10) const {
    const std::regex re(pattern);
    const auto end =
        std::chrono::steady_clock::now() +
        std::chrono::milliseconds(static_cast<int>(timeout_s * 1e3));
    while (std::chrono::steady_clock::now() < end) {
      std::smatch match;
      const std::string text = Output();
      if (std::regex_search(text, match, re)) {
        return match.size() > 1 ? match[1].str() : match[0].str();
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return "";
  }

  // Exit code, -signal when killed by a signal, or -1000 on timeout.
  int Wait(double timeout_s = 60) {
    const auto end =
        std::chrono::steady_clock::now() +
        std::chrono::milliseconds(static_cast<int>(timeout_s * 1e3));
    int status = 0;
    while (std::chrono::steady_clock::now() < end) {
      struct rusage usage {};
      if (wait4(pid_, &status, WNOHANG, &usage) == pid_) {
        peak_rss_kib_ = usage.ru_maxrss;
        reaped_ = true;
        if (WIFEXITED(status)) return WEXITSTATUS(status);
        return -WTERMSIG(status);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return -1000;
  }

 private:
  std::string output_path_;
  pid_t pid_ = -1;
  bool reaped_ = false;
  long peak_rss_kib_ = 0;
};

}  // namespace kcrig

#endif  // KCRIG_TESTS_SUPPORT_CHILD_PROCESS_H_

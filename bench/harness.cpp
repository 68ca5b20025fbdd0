#include "harness.hpp"

#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>

#include <algorithm>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "graintwin/core/strings.hpp"

extern char** environ;

namespace graintwin::bench {

double best_seconds(int reps, const std::function<void()>& f) {
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i < reps; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return best;
}

Row run_child(const std::string& case_name, const std::string& implementation, const std::vector<std::string>& argv,
              int reps) {
  Row row{case_name, implementation, std::numeric_limits<double>::infinity(), 0.0, ""};
  for (int i = 0; i < reps; ++i) {
    std::vector<std::string> args = argv;
    std::vector<char*> cargv;
    for (auto& a : args) cargv.push_back(a.data());
    cargv.push_back(nullptr);
    const auto t0 = std::chrono::steady_clock::now();
    pid_t pid = 0;
    if (posix_spawnp(&pid, cargv[0], nullptr, nullptr, cargv.data(), environ) != 0)
      throw std::runtime_error("cannot start " + argv[0]);
    int status = 0;
    rusage ru{};
    wait4(pid, &status, 0, &ru);
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
      throw std::runtime_error(implementation + " failed on " + case_name + " (" + argv[0] + ")");
    row.seconds = std::min(row.seconds, secs);
    row.peak_bytes = std::max(row.peak_bytes, static_cast<double>(ru.ru_maxrss) * 1024.0);
  }
  return row;
}

double self_peak_rss_bytes() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return static_cast<double>(ru.ru_maxrss) * 1024.0;
}

Report::Report(std::string name, std::string title, std::string method)
    : name_(std::move(name)), title_(std::move(title)), method_(std::move(method)) {}

std::string Report::markdown(const std::string& reference) const {
  std::map<std::string, const Row*> ref;
  for (const auto& r : rows_)
    if (r.implementation == reference) ref[r.case_name] = &r;
  std::ostringstream s;
  s << "| case | implementation | time (s) | time / " << reference << " | peak memory (MB) | memory / " << reference
    << " | note |\n|---|---|---|---|---|---|---|\n";
  char buf[64];
  for (const auto& r : rows_) {
    const Row* base = ref.count(r.case_name) ? ref[r.case_name] : nullptr;
    s << "| " << r.case_name << " | " << r.implementation << " | ";
    std::snprintf(buf, sizeof buf, "%.3g", r.seconds);
    s << buf << " | ";
    if (base && base->seconds > 0) {
      std::snprintf(buf, sizeof buf, "%.3g", r.seconds / base->seconds);
      s << buf;
    }
    s << " | ";
    if (r.peak_bytes > 0) {
      std::snprintf(buf, sizeof buf, "%.0f", r.peak_bytes / 1e6);
      s << buf;
    }
    s << " | ";
    if (base && base->peak_bytes > 0 && r.peak_bytes > 0) {
      std::snprintf(buf, sizeof buf, "%.2g", r.peak_bytes / base->peak_bytes);
      s << buf;
    }
    s << " | " << r.note << " |\n";
  }
  return s.str();
}

std::filesystem::path bin_dir() { return std::filesystem::read_symlink("/proc/self/exe").parent_path(); }

std::string machine_summary() {
  std::ifstream cpu("/proc/cpuinfo");
  std::string line, model = "unknown CPU";
  while (std::getline(cpu, line))
    if (line.rfind("model name", 0) == 0) {
      model = trim(line.substr(line.find(':') + 1));
      break;
    }
  return model + ", " + std::to_string(std::thread::hardware_concurrency()) + " cores, " + utc_now_iso8601();
}

void Report::publish(const std::string& reference, const std::filesystem::path& benchmarks_md) const {
  const std::string table = markdown(reference);
  std::cout << "\n" << title_ << "\n\n" << table << std::endl;
  const std::string begin = "<!-- bench:" + name_ + " -->", end = "<!-- /bench:" + name_ + " -->";
  const std::string section = begin + "\n## " + title_ + "\n\n" + method_ + "\n\nMeasured on " + machine_summary() +
                              " by `" + name_ + "`.\n\n" + table + end;
  std::string doc;
  {
    std::ifstream in(benchmarks_md);
    std::ostringstream ss;
    ss << in.rdbuf();
    doc = ss.str();
  }
  if (doc.empty()) doc = "# Benchmarks\n\nEvery section below is written by the bench/ program it names; do not edit by hand.\n";
  const auto b = doc.find(begin), e = doc.find(end);
  if (b != std::string::npos && e != std::string::npos && e > b)
    doc.replace(b, e + end.size() - b, section);
  else
    doc += "\n" + section + "\n";
  std::ofstream(benchmarks_md) << doc;
  std::cout << "updated " << benchmarks_md.string() << " (section " << name_ << ")\n";
}

bool parse_quick_work(int argc, char** argv, bool& quick, std::filesystem::path& work) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") quick = true;
    else if (a == "--work" && i + 1 < argc) work = argv[++i];
    else return false;
  }
  return true;
}

bool plot_xy(const std::filesystem::path& csv, const std::filesystem::path& png, const std::string& title,
             const std::string& x_label, const std::string& y_label) {
  const std::string script = std::string(GRAINTWIN_SOURCE_DIR) + "/bench/plot_xy.py";
  try {
    run_child("chart", "plot_xy.py", {"/usr/bin/python3", script, csv.string(), png.string(), title, x_label, y_label});
    return true;
  } catch (const std::exception& e) {
    std::cerr << "the chart " << png.string() << " was not drawn: " << e.what() << "\n";
    return false;
  }
}

}  // namespace graintwin::bench

#include "graintwin/report/page.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"

extern char** environ;

namespace graintwin::report {

std::string base64(std::string_view bytes) {
  static constexpr char alphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const std::uint32_t v = std::uint32_t(std::uint8_t(bytes[i])) << 16 | std::uint32_t(std::uint8_t(bytes[i + 1])) << 8 |
                            std::uint32_t(std::uint8_t(bytes[i + 2]));
    out += {alphabet[v >> 18], alphabet[(v >> 12) & 63], alphabet[(v >> 6) & 63], alphabet[v & 63]};
  }
  if (i + 1 == bytes.size()) {
    const std::uint32_t v = std::uint32_t(std::uint8_t(bytes[i])) << 16;
    out += {alphabet[v >> 18], alphabet[(v >> 12) & 63], '=', '='};
  } else if (i + 2 == bytes.size()) {
    const std::uint32_t v = std::uint32_t(std::uint8_t(bytes[i])) << 16 | std::uint32_t(std::uint8_t(bytes[i + 1])) << 8;
    out += {alphabet[v >> 18], alphabet[(v >> 12) & 63], alphabet[(v >> 6) & 63], '='};
  }
  return out;
}

std::string html_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

namespace {

/// Tools in the order their stages run, with the stage (Makefile.pipeline target) of each; "fdem"
/// names the benches of fdemrun's library parts (contact, membrane).
constexpr std::array<std::pair<const char*, const char*>, 13> kToolStages{{
    {"ctsynth", "synthetic scans (no pipeline stage)"},
    {"volconvert", "import (no pipeline stage)"},
    {"volinfo", "inspect"},
    {"ct2labels", "segment"},
    {"labels2contacts", "contacts"},
    {"labels2shapes", "shapes"},
    {"shapes2tracks", "track"},
    {"shapes2mesh", "mesh"},
    {"fdemrun", "simulate"},
    {"fdem", "simulate"},
    {"tracks2micro", "micro"},
    {"fdem2forces", "forces"},
    {"report", "report"},
}};

std::size_t tool_order(const std::string& tool) {
  for (std::size_t k = 0; k < kToolStages.size(); ++k)
    if (tool == kToolStages[k].first) return k;
  return kToolStages.size();
}

void image(std::ostringstream& out, const std::string& png, const std::string& alt) {
  out << "<img alt=\"" << html_escape(alt) << "\" src=\"data:image/png;base64," << base64(png) << "\">\n";
}

}  // namespace

std::string read_binary_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw DataError("cannot read " + path.string() + "; check that it exists and is readable");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string stage_of_tool(const std::string& tool) {
  const std::size_t k = tool_order(tool);
  return k < kToolStages.size() ? kToolStages[k].second : "";
}

std::vector<BenchChart> find_bench_charts(const fs::path& dir) {
  std::vector<BenchChart> charts;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return charts;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const fs::path& p = e.path();
    if (p.extension() != ".png") continue;
    const std::string stem = p.stem().string();
    std::string tool;
    for (const auto& [name, stage] : kToolStages)
      if (stem.rfind(std::string(name) + "_", 0) == 0 && std::string(name).size() > tool.size()) tool = name;
    const bool drawn_by_bench = fs::exists(p.parent_path() / (stem + ".csv"), ec) || stem.find("accuracy") != std::string::npos;
    if (!tool.empty() && drawn_by_bench) charts.push_back({p, tool, stage_of_tool(tool)});
  }
  std::sort(charts.begin(), charts.end(), [](const BenchChart& a, const BenchChart& b) {
    return std::pair(tool_order(a.tool), a.file.filename()) < std::pair(tool_order(b.tool), b.file.filename());
  });
  return charts;
}

std::string report_html(const PageContent& c) {
  std::size_t total_images = c.bench_charts.size();
  for (const Panel& p : c.panels) total_images += (p.experiment.chart ? 1 : 0) + (p.simulation.chart ? 1 : 0);
  for (const BudgetLine& l : c.budget) total_images += l.chart ? 1 : 0;
  std::ostringstream o;
  o << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" << html_escape(c.title) << "</title>\n"
    << "<style>\n"
       "body{font-family:sans-serif;margin:1.5em auto;max-width:1400px;padding:0 1em;color:#222}\n"
       "h1{margin-bottom:0.2em} h2{border-bottom:1px solid #ccc;padding-bottom:0.2em;margin-top:1.6em}\n"
       "table.summary{border-collapse:collapse} table.summary td{border:1px solid #ddd;padding:0.2em 0.6em}\n"
       ".sides{display:flex;gap:1em;flex-wrap:wrap} .side{flex:1 1 600px;margin:0;border:1px solid #eee;padding:0.5em}\n"
       ".side figcaption{font-weight:bold;margin-bottom:0.3em} .side img,.bench img{max-width:100%}\n"
       ".missing{background:#fff6e0;border-left:4px solid #e0a000;padding:0.6em} .note{font-size:0.9em;color:#444}\n"
       ".what{color:#444} nav ol{columns:3} details{margin-top:2em} details li{font-family:monospace;font-size:0.85em}\n"
       ".bench{display:inline-block;width:48%;vertical-align:top;margin:0 1% 1em 0}\n"
       ".budget{display:inline-block;width:48%;vertical-align:top;margin:0 1% 1em 0;border:1px solid #eee;padding:0.5em}\n"
       ".budget img{max-width:100%} .budget .value{font-size:1.3em;font-weight:bold}\n"
       "</style>\n</head>\n";
  o << "<body data-images-total=\"" << total_images << "\" data-images-loaded=\"pending\">\n";
  o << "<h1>" << html_escape(c.title) << "</h1>\n"
    << "<p>Experiment (CT scans) and simulation (FDEM twin) side by side: first pictures of the sample (sections through the scans "
       "and the twin, D2min and eps_q on them, the high-D2min clusters and the force-chain network in 3D), then one panel per "
       "chart; the numbers behind every picture and chart are "
       "in the report's image folder (charts.json). Made by <code>"
    << html_escape(c.generated_by) << "</code>.</p>\n";
  o << "<table class=\"summary\">\n";
  for (const auto& [item, value] : c.summary) o << "<tr><td>" << html_escape(item) << "</td><td>" << html_escape(value) << "</td></tr>\n";
  o << "</table>\n<nav><ol>\n";
  for (const Panel& p : c.panels) o << "<li><a href=\"#" << p.id << "\">" << html_escape(p.title) << "</a></li>\n";
  o << "<li><a href=\"#budget\">Error budget</a></li>\n<li><a href=\"#bench\">Accuracy against time per stage</a></li>\n<li><a href=\"#provenance\">Provenance</a></li>\n</ol></nav>\n";
  for (const Panel& p : c.panels) {
    o << "<section class=\"panel\" id=\"" << p.id << "\">\n<h2>" << html_escape(p.title) << "</h2>\n<p class=\"what\">"
      << html_escape(p.description) << "</p>\n<div class=\"sides\">\n";
    for (const auto& [side, caption] : {std::pair{&p.experiment, "Experiment (CT scans)"}, std::pair{&p.simulation, "Simulation (FDEM)"}}) {
      o << "<figure class=\"side\"><figcaption>" << caption << "</figcaption>\n";
      if (side->chart) {
        const auto it = c.images.find(side->chart->file);
        if (it == c.images.end()) throw DataError("the chart " + side->chart->file + " of panel " + p.id + " was not drawn; check the chart script");
        image(o, it->second, p.title + ", " + caption);
        if (!side->note.empty()) o << "<p class=\"note\">" << html_escape(side->note) << "</p>\n";
      } else {
        o << "<p class=\"missing\">" << html_escape(side->missing) << "</p>\n";
      }
      o << "</figure>\n";
    }
    o << "</div>\n</section>\n";
  }
  o << "<section id=\"budget\">\n<h2>Error budget</h2>\n";
  if (c.budget.empty()) o << "<p class=\"missing\">" << html_escape(kNoValidation) << "</p>\n";
  else
    o << "<p class=\"what\">Every stage of this run scored against the series' ground truth (validation.json, written by the validate "
         "stage; docs/validate.md): one line per item, its number and its chart.</p>\n";
  for (const BudgetLine& l : c.budget) {
    o << "<figure class=\"budget\" id=\"budget_" << l.id << "\"><figcaption>" << html_escape(l.title) << ": <span class=\"value\">"
      << html_escape(l.value) << "</span></figcaption>\n<p class=\"what\">" << html_escape(l.description) << "</p>\n";
    if (l.chart) {
      const auto it = c.images.find(l.chart->file);
      if (it == c.images.end()) throw DataError("the chart " + l.chart->file + " of the error budget was not drawn; check the chart script");
      image(o, it->second, l.title);
    } else {
      o << "<p class=\"missing\">" << html_escape(l.missing) << "</p>\n";
    }
    o << "</figure>\n";
  }
  o << "</section>\n";
  o << "<section id=\"bench\">\n<h2>Accuracy against time per stage</h2>\n"
       "<p class=\"what\">The benchmark charts of each stage's fidelity knob (bench/ programs, docs/benchmarks.md), grouped by "
       "the pipeline stage whose tool they measure.</p>\n";
  if (c.bench_charts.empty()) o << "<p class=\"missing\">No benchmark charts were found (--bench-img).</p>\n";
  for (const auto& [chart, png] : c.bench_charts) {
    const std::string caption = "stage " + chart.stage + ": " + chart.tool + " (" + chart.file.filename().string() + ")";
    o << "<figure class=\"bench\"><figcaption>" << html_escape(caption) << "</figcaption>\n";
    image(o, png, caption);
    o << "</figure>\n";
  }
  o << "</section>\n<details id=\"provenance\">\n<summary>Provenance: how each file of the run was made</summary>\n";
  for (const auto& [file, lines] : c.provenance) {
    o << "<h3>" << html_escape(file) << "</h3>\n<ol>\n";
    for (const std::string& l : lines) o << "<li>" << html_escape(l) << "</li>\n";
    o << "</ol>\n";
  }
  o << "</details>\n"
       "<script>\n"
       "window.addEventListener('load', function () {\n"
       "  var loaded = 0;\n"
       "  for (var i = 0; i < document.images.length; ++i)\n"
       "    if (document.images[i].complete && document.images[i].naturalWidth > 0) ++loaded;\n"
       "  document.body.setAttribute('data-images-loaded', String(loaded));\n"
       "});\n"
       "</script>\n</body>\n</html>\n";
  return o.str();
}

namespace {

/// Starts `argv` (argv[0] a path, no PATH search) with stdin from /dev/null and stdout and stderr
/// into `log`. The child is killed by the kernel when the thread that started it ends, so it
/// cannot outlive this process even after a SIGKILL. Returns the child's pid; DataError (without
/// the fix, which the caller knows) when it cannot start, with the reason.
pid_t start_child(std::vector<std::string> args, const fs::path& log) {
  // Everything the child needs is prepared here: between fork and exec only async-signal-safe
  // calls are allowed (other threads may hold the allocator's locks).
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const int in = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  const int out = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  int report[2] = {-1, -1};  // the child writes errno here when exec fails; exec closes it otherwise
  const bool ready = in >= 0 && out >= 0 && ::pipe2(report, O_CLOEXEC) == 0;
  const int open_errno = errno;
  const pid_t parent = ::getpid();
  const pid_t pid = ready ? ::fork() : -1;
  if (pid == 0) {
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(127);  // the parent died before prctl took effect
    // dup2 onto itself would keep close-on-exec: a descriptor already in place only loses the flag.
    const auto onto = [](int fd, int target) { return fd == target ? ::fcntl(fd, F_SETFD, 0) : ::dup2(fd, target); };
    int e = 0;
    if (onto(in, STDIN_FILENO) < 0 || onto(out, STDOUT_FILENO) < 0 || onto(out, STDERR_FILENO) < 0)
      e = errno;
    else
      ::execve(argv[0], argv.data(), environ), e = errno;
    (void)!::write(report[1], &e, sizeof e);
    ::_exit(127);
  }
  const int fork_errno = errno;
  for (int fd : {in, out, report[1]})
    if (fd >= 0) ::close(fd);
  if (pid < 0) {
    if (report[0] >= 0) ::close(report[0]);
    throw DataError(std::strerror(ready ? fork_errno : open_errno));
  }
  int exec_errno = 0;
  ssize_t got = 0;
  while ((got = ::read(report[0], &exec_errno, sizeof exec_errno)) < 0 && errno == EINTR) {
  }
  ::close(report[0]);
  if (got > 0) {
    while (::waitpid(pid, nullptr, 0) < 0 && errno == EINTR) {
    }
    throw DataError(std::strerror(exec_errno));
  }
  return pid;
}

}  // namespace

void run_chart_script(const fs::path& python, const fs::path& script, const fs::path& charts_json, const fs::path& out_dir) {
  const fs::path log = out_dir / "chart_script.log";
  pid_t pid = 0;
  try {
    pid = start_child({python.string(), script.string(), charts_json.string(), out_dir.string()}, log);
  } catch (const DataError& e) {
    throw DataError("cannot start " + python.string() + " for the charts (" + e.message() +
                    "); install Debian's python3 and python3-matplotlib (scripts/deps.sh) or pass --python");
  }
  // Polled rather than blocking, so that an interrupt (which only sets a flag) ends the script too.
  int status = 0;
  for (;;) {
    const pid_t done = ::waitpid(pid, &status, WNOHANG);
    if (done == pid || (done < 0 && errno != EINTR)) break;
    if (interrupted()) {
      ::kill(pid, SIGKILL);
      while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
      }
      throw InterruptedError();
    }
    ::usleep(20000);
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::string text = read_binary_file(log), tail;
    std::istringstream lines(text);
    std::vector<std::string> all;
    for (std::string l; std::getline(lines, l);) all.push_back(l);
    for (std::size_t k = all.size() > 5 ? all.size() - 5 : 0; k < all.size(); ++k) tail += (tail.empty() ? "" : " | ") + all[k];
    throw DataError("the chart script " + script.string() + " failed (" + tail +
                    "); check that Debian's python3-matplotlib is installed (scripts/deps.sh)");
  }
  std::error_code ec;
  fs::remove(log, ec);
}

}  // namespace graintwin::report

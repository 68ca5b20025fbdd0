#include "graintwin/cli/tool.hpp"

#include <omp.h>
#include <toml++/toml.h>
#include <spdlog/sinks/stdout_color_sinks.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <iostream>
#include <sstream>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"
#include "graintwin/core/message.hpp"
#include "graintwin/core/strings.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/version.hpp"

namespace graintwin::cli {

namespace fs = std::filesystem;

std::unique_ptr<Progress> RunContext::progress(const std::string& label, std::size_t total) const {
  return std::make_unique<Progress>(name_ + ": " + label, total, !quiet_);
}

std::function<void(double)> RunContext::progress_callback(const std::string& label) const {
  constexpr std::size_t steps = 1000;
  auto bar = std::shared_ptr<Progress>(progress(label, steps));
  auto shown = std::make_shared<std::size_t>(0);
  return [bar, shown](double fraction) {
    const auto now = static_cast<std::size_t>(std::clamp(fraction, 0.0, 1.0) * steps);
    if (now > *shown) {
      bar->advance(now - *shown);
      *shown = now;
    }
  };
}

void RunContext::add_input_history(const io::H5File& input) {
  io::declare_input(input.path());  // an input read by name from an option is no output either
  io::merge_history(inputs_history_, io::read_history(input));
}

std::vector<std::string> RunContext::history() const {
  std::vector<std::string> h = inputs_history_;
  h.push_back(line_);
  return h;
}

Tool::Tool(std::string name, std::string description) : name_(std::move(name)), app_(description, name_) {
  app_.set_help_flag("-h,--help", "Print this help and exit");
  app_.set_version_flag("--version", std::string(name_) + " (graintwin " + graintwin::version + ", git " +
                                         graintwin::git_revision + ")");
  app_.add_flag("-q,--quiet", quiet_, "Errors only: no progress, no information messages");
  app_.add_flag("-v,--verbose", verbosity_, "More messages (repeat for debug output)");
  app_.add_flag("-f,--force", force_, "Overwrite existing outputs");
  app_.add_option("-j,--threads", threads_, "Worker threads (0 = all cores)")
      ->check(whole_number_in(0, kMaxThreads))
      ->capture_default_str();
  app_.set_config("--config", "", "Read options from a TOML file (keys = long option names)");
  app_.allow_config_extras(CLI::config_extras_mode::error);  // a misspelt key must not pass silently
  app_.get_formatter()->column_width(34);
}

CLI::Option* Tool::add_input(const std::string& name, fs::path& target, const std::string& description,
                             bool must_exist) {
  (must_exist ? inputs_ : unchecked_inputs_).push_back(&target);
  return app_.add_option(name, target, description)->required();
}

CLI::Option* Tool::add_optional_input(const std::string& name, fs::path& target, const std::string& description) {
  optional_input_ = &target;
  return app_.add_option(name, target, description + " (optional)");
}

CLI::Option* Tool::add_output(const std::string& name, fs::path& target, const std::string& description) {
  outputs_.push_back(&target);
  output_names_.push_back(name);
  CLI::Option* o = app_.add_option(name, target, description);
  // CLI11 fills positionals greedily from the left, so after an optional input the outputs are
  // checked in run(), once the arguments have been shifted.
  return optional_input_ ? o : o->required();
}

void Tool::use_positional_config(const std::string& name, fs::path& target, const std::string& description) {
  config_positional_ = app_.set_config(name, "", description, true);
  config_target_ = &target;
  inputs_.push_back(&target);
}

void Tool::share_cores_with(int processes) {
  sharing_processes_ = std::max(1, processes);
  app_.get_option("--threads")
      ->description("Worker threads (0 = all cores; under mpirun, each rank an equal share of its machine's cores)");
}

void Tool::set_examples(const std::vector<std::string>& examples) {
  std::string footer = "\nExamples:\n";
  for (const auto& e : examples) footer += "  " + e + "\n";
  footer += "\nExit codes: 0 ok, 1 data error, 2 usage error, 130 interrupted.\nDocs: docs/tools/" + name_ + ".md";
  app_.footer(footer);
}

std::string Tool::effective_config() const {
  std::istringstream all(app_.config_to_str(true, false));
  std::string out, line;
  while (std::getline(all, line))
    if (!line.ends_with("=\"\"")) out += line + "\n";
  return out;
}

std::string Tool::config_file_problem(int argc, char** argv) const {
  fs::path file;
  for (int i = 1; i + 1 < argc && file.empty(); ++i)
    if (std::string(argv[i]) == "--config") file = argv[i + 1];
  for (int i = 1; i < argc && file.empty(); ++i)
    if (std::string(argv[i]).starts_with("--config=")) file = std::string(argv[i]).substr(9);
  for (int i = 1; i < argc && file.empty() && config_positional_; ++i) {
    std::error_code ec;
    if (argv[i][0] != '-' && fs::is_regular_file(argv[i], ec)) file = argv[i];
  }
  if (file.empty()) return {};
  toml::table root;
  try {
    root = toml::parse_file(file.string());
  } catch (const toml::parse_error& e) {
    return file.string() + " line " + std::to_string(e.source().begin.line) + ": " + shorten_quotes(std::string(e.description())) +
           "; fix the TOML syntax";
  }
  std::vector<std::string> names;
  for (const CLI::Option* o : app_.get_options())
    if (o->get_lnames().empty())
      names.push_back(o->get_single_name());  // a positional, by its name
    else
      for (const std::string& n : o->get_lnames()) names.push_back(n);
  for (auto&& [k, v] : root) {
    const std::string key(k.str());
    if (std::find(names.begin(), names.end(), key) != names.end()) continue;
    const std::string hint = closest_name(key, names);
    return file.string() + ": key '" + key + "' is not an option of " + name_ +
           (hint.empty() ? "; see " + name_ + " --help for the option names" : "; did you mean '" + hint + "'?");
  }
  return {};
}

namespace {
void print_error(spdlog::logger& log, const Error& e) {
  log.error("{}", e.message());
  for (const auto& c : e.context()) log.error("  {}", c);
}
}  // namespace

int Tool::run(int argc, char** argv, const std::function<void(RunContext&)>& body) {
  auto sink = std::make_shared<spdlog::sinks::stderr_color_sink_mt>();
  if (std::getenv("NO_COLOR")) sink->set_color_mode(spdlog::color_mode::never);
  auto log = std::make_shared<spdlog::logger>(name_, sink);
  log->set_pattern("%n: [%l] %v");
  spdlog::set_default_logger(log);

  try {
    app_.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app_.exit(e);  // --help and --version print to stdout
    // A broken configuration file explains more than the option error it caused.
    const std::string config_error = config_file_problem(argc, argv);
    std::cerr << name_ << ": " << (config_error.empty() ? std::string(e.what()) : config_error) << "\n"
              << name_ << ": run '" << name_ << " --help' for the options\n";
    return static_cast<int>(ExitCode::usage_error);
  }
  // CLI11 reads a key given twice as its last value; TOML forbids it, and a silent choice between two
  // values the user wrote is no choice.
  if (const std::string config_error = config_file_problem(argc, argv); !config_error.empty()) {
    std::cerr << name_ << ": " << config_error << "\n" << name_ << ": run '" << name_ << " --help' for the options\n";
    return static_cast<int>(ExitCode::usage_error);
  }
  if (config_positional_) *config_target_ = config_positional_->as<std::string>();
  if (optional_input_) {
    // One argument short: the optional input took what belongs to the outputs.
    for (std::size_t i = outputs_.size(); i-- > 0;) {
      if (!outputs_[i]->empty()) break;
      *outputs_[i] = i > 0 ? *outputs_[i - 1] : *optional_input_;
      (i > 0 ? *outputs_[i - 1] : *optional_input_).clear();
    }
    for (std::size_t i = 0; i < outputs_.size(); ++i)
      if (outputs_[i]->empty()) {
        std::cerr << name_ << ": " << output_names_[i] << " is required\nRun with --help for more information.\n";
        return static_cast<int>(ExitCode::usage_error);
      }
    if (!optional_input_->empty()) inputs_.push_back(optional_input_);
  }
  log->set_level(quiet_ ? spdlog::level::err
                        : verbosity_ >= 2 ? spdlog::level::trace
                        : verbosity_ == 1 ? spdlog::level::debug
                                          : spdlog::level::info);
  RunContext ctx;
  ctx.name_ = name_;
  ctx.force_ = force_;
  ctx.quiet_ = quiet_;
  ctx.threads_ = threads_ > 0 ? threads_ : std::max(1, omp_get_num_procs() / sharing_processes_);
  omp_set_num_threads(ctx.threads_);
  std::string cmd = name_;
  for (int i = 1; i < argc; ++i) cmd += " " + shell_quote(argv[i]);
  ctx.line_ = cmd + "  (graintwin " + graintwin::version + ", git " + graintwin::git_revision + ", " +
              utc_now_iso8601() + ")";
  install_interrupt_handlers();
  const auto t0 = std::chrono::steady_clock::now();
  try {
    // Validate before heavy work (PDAL style): inputs exist, outputs may be written and are no input.
    for (const fs::path* in : inputs_) {
      std::error_code ec;
      if (!fs::exists(*in, ec)) throw UsageError("input " + in->string() + " does not exist; check the path");
      io::declare_input(*in);
    }
    for (const fs::path* in : unchecked_inputs_) io::declare_input(*in);
    for (const fs::path* out : outputs_) io::check_output_allowed(*out, force_);
    log->info("{}", ctx.line_);
    body(ctx);
    if (!commit_point_passed()) throw_if_interrupted();  // after it, a signal is ignored
  } catch (const InterruptedError& e) {
    log->error("interrupted; no output was written");
    return static_cast<int>(e.exit_code());
  } catch (const Error& e) {
    print_error(*log, e);
    return static_cast<int>(e.exit_code());
  } catch (const CLI::Error& e) {
    log->error("{}", e.what());
    return static_cast<int>(ExitCode::usage_error);
  } catch (const std::bad_alloc&) {
    log->error("out of memory; give a smaller input or lower the option that sets the size of the work");
    return static_cast<int>(ExitCode::data_error);
  } catch (const std::length_error& e) {
    log->error("a size too large to hold in memory came from the input or options ({}); check the sizes given",
               e.what());
    return static_cast<int>(ExitCode::data_error);
  } catch (const std::exception& e) {
    log->error("{}", e.what());
    return static_cast<int>(ExitCode::data_error);
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  log->info("done in {:.2f} s", secs);
  return 0;
}

}  // namespace graintwin::cli

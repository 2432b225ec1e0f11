// What the apps print (apps/common/console.hpp, help.hpp): progress lines paced by a clock the test sets, the start
// table's names and units from the summary keys' suffixes, and --help's groups, defaults, units and ranges.
#include <gtest/gtest.h>
#include <unistd.h>
#include <sys/stat.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "checks.hpp"
#include "console.hpp"
#include "help.hpp"

namespace {

// A FILE* whose text the test reads back.
class Captured {
 public:
  Captured() : file_(open_memstream(&data_, &size_)) {}
  ~Captured() {
    if (file_ != nullptr) std::fclose(file_);
    std::free(data_);
  }
  Captured(const Captured&) = delete;
  Captured& operator=(const Captured&) = delete;
  std::FILE* file() { return file_; }
  std::string text() {
    std::fflush(file_);
    return std::string(data_, size_);
  }

 private:
  char* data_ = nullptr;
  std::size_t size_ = 0;
  std::FILE* file_;
};

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::size_t at = 0;
  for (std::size_t end; (end = text.find('\n', at)) != std::string::npos; at = end + 1)
    lines.push_back(text.substr(at, end - at));
  return lines;
}

}  // namespace

TEST(Progress, PlainLineEveryIntervalOfWallTimeAndALastOneWhenNotATerminal) {
  Captured out;
  double now = 0;
  Progress progress(100, "s", 10, false, out.file(), [&] { return now; });
  for (int step = 1; step <= 35; ++step) {  // one second of wall time and two of simulated time a step
    now = step;
    progress.update(2.0 * step, step);
  }
  progress.finish(70, 35);
  const auto lines = lines_of(out.text());
  // At 10, 20 and 30 s of wall time, then the last. The pace since the first step (t = 2 at 1 s) is 2 s a second:
  // 80 s of simulated time left at 10 s is 40 s of wall time.
  ASSERT_EQ(lines.size(), 4u) << out.text();
  EXPECT_EQ(lines[0], "progress: t = 20 / 100 s   20.0 %  step 10  wall 0:10  ETA 0:40");
  EXPECT_EQ(lines[1], "progress: t = 40 / 100 s   40.0 %  step 20  wall 0:20  ETA 0:30");
  EXPECT_EQ(lines[2], "progress: t = 60 / 100 s   60.0 %  step 30  wall 0:30  ETA 0:20");
  EXPECT_EQ(lines[3], "progress: t = 70 / 100 s   70.0 %  step 35  done in 0:35");
  EXPECT_EQ(out.text().find('\r'), std::string::npos);
}

TEST(Progress, AStallPrintsOneLineAndTheNextComesAtTheNextInterval) {
  Captured out;
  double now = 0;
  Progress progress(10, "D/U", 10, false, out.file(), [&] { return now; });
  now = 1;
  progress.update(1, 1);
  now = 25;  // a step that took 24 s
  progress.update(2, 2);
  now = 29;
  progress.update(3, 3);
  now = 30;
  progress.update(4, 4);
  const auto lines = lines_of(out.text());
  ASSERT_EQ(lines.size(), 2u) << out.text();
  EXPECT_NE(lines[0].find("t = 2 / 10 D/U"), std::string::npos);
  EXPECT_NE(lines[1].find("t = 4 / 10 D/U"), std::string::npos);
}

TEST(Progress, OnATerminalOneLineIsRedrawnInPlaceAndClearedForOtherOutput) {
  Captured out;
  double now = 0;
  Progress progress(1, "s", 10, true, out.file(), [&] { return now; });
  for (int step = 1; step <= 20; ++step) {  // 0.1 s apart: drawn at the first step, then every 0.25 s at most
    now = 0.1 * step;
    progress.update(0.05 * step, step);
  }
  const std::string drawn = out.text();
  EXPECT_EQ(drawn.find('\n'), std::string::npos) << "a terminal line ends only with the run";
  EXPECT_EQ(static_cast<long>(std::count(drawn.begin(), drawn.end(), '\r')), 7) << drawn;  // steps 1, 4, 7, ... 19
  EXPECT_NE(drawn.find("\rt = 0.95 / 1 s   95.0 %  step 19  wall 0:02  ETA 0:00\033[K"), std::string::npos) << drawn;
  progress.clear();
  EXPECT_EQ(out.text().substr(drawn.size()), "\r\033[K");
  now = 2.05;
  progress.update(1.0, 20);  // redrawn at once after a clear
  progress.finish(1.0, 20);
  const std::string all = out.text();
  EXPECT_NE(all.find("\r\033[K\rt = 1 / 1 s  100.0 %  step 20  wall 0:02"), std::string::npos) << all;
  const std::string last = "\rt = 1 / 1 s  100.0 %  step 20  done in 0:02\033[K\n";
  ASSERT_GE(all.size(), last.size());
  EXPECT_EQ(all.substr(all.size() - last.size()), last);
}

// Under mpirun a rank's stdout is a pseudo-terminal even when the log goes to a file: plain lines there.
TEST(Progress, PlainLinesUnderAnMpiLauncherEvenOnATerminal) {
  const char* before = std::getenv("OMPI_COMM_WORLD_SIZE");
  const std::string saved = before ? before : "";
  unsetenv("OMPI_COMM_WORLD_SIZE");
  const bool alone = redraw_in_place(true);
  setenv("OMPI_COMM_WORLD_SIZE", "2", 1);
  const bool launched = redraw_in_place(true);
  if (before) setenv("OMPI_COMM_WORLD_SIZE", saved.c_str(), 1); else unsetenv("OMPI_COMM_WORLD_SIZE");
  EXPECT_TRUE(alone || std::getenv("PMI_SIZE") || std::getenv("PMIX_RANK") || std::getenv("MPI_LOCALNRANKS"));
  EXPECT_FALSE(launched);
  EXPECT_FALSE(redraw_in_place(false));
}

TEST(Progress, DurationsAsMinutesAndSecondsOrHours) {
  EXPECT_EQ(Progress::duration(0), "0:00");
  EXPECT_EQ(Progress::duration(65.4), "1:05");
  EXPECT_EQ(Progress::duration(3725), "1:02:05");
}

TEST(ParameterTable, NamesAndUnitsComeFromTheSummaryKeysSuffixes) {
  EXPECT_EQ(name_and_unit("nu_m2_per_s"), std::make_pair(std::string("nu"), std::string("m^2/s")));
  EXPECT_EQ(name_and_unit("body_force_m_per_s2"), std::make_pair(std::string("body force"), std::string("m/s^2")));
  EXPECT_EQ(name_and_unit("rho_kg_per_m3"), std::make_pair(std::string("rho"), std::string("kg/m^3")));
  EXPECT_EQ(name_and_unit("end_time_D_over_U"), std::make_pair(std::string("end time"), std::string("D/U")));
  EXPECT_EQ(name_and_unit("tolerance_over_eps"), std::make_pair(std::string("tolerance"), std::string("eps")));
  EXPECT_EQ(name_and_unit("station_D"), std::make_pair(std::string("station"), std::string("D")));
  EXPECT_EQ(name_and_unit("radius_l0"), std::make_pair(std::string("radius"), std::string("l0")));
  EXPECT_EQ(name_and_unit("omega_rad_per_s"), std::make_pair(std::string("omega"), std::string("rad/s")));
  EXPECT_EQ(name_and_unit("dt_max_s"), std::make_pair(std::string("dt max"), std::string("s")));
  EXPECT_EQ(name_and_unit("average_fraction"), std::make_pair(std::string("average fraction"), std::string()));
  EXPECT_EQ(name_and_unit("gamma"), std::make_pair(std::string("gamma"), std::string()));
}

TEST(ParameterTable, GroupsAlignInCellsAndSkipWhatTheRunDoesNotHave) {
  const nlohmann::json params = {{"width_m", 0.2}, {"nu_m2_per_s", 1e-6}, {"mode", "inlet"},
                                 {"radii", {{"density_l0", 4.1}}}, {"end_time_D_over_U", 10.0},
                                 {"times_s", {0.05, 0.5}}, {"maps_s", nlohmann::json::array()},
                                 {"frequency_hz", nullptr}, {"wet_walls", true}};
  const std::string table =
      parameter_table("poiseuille: a title", params,
                      {{"scene", {"mode", "width_m", "nu_m2_per_s", "absent_m", "frequency_hz"}},
                       {"run", {"end_time_D_over_U", "times_s", "maps_s", "radii/density_l0", "wet_walls"}},
                       {"empty", {"absent_m"}}});
  EXPECT_EQ(table,
            "poiseuille: a title\n"
            "  scene      mode = inlet          width = 0.2 m         nu = 1e-06 m^2/s\n"
            "  run        end time = 10 D/U     times = 0.05, 0.5 s   density = 4.1 l0      wet walls = yes\n");
}

TEST(GroupedHelp, OptionsInGroupsWithDefaultUnitAndRange) {
  CLI::App app{"a scene"};
  add_general_options(app);
  double width = 0.2, dx = 0, gamma = 0.5;
  bool cold = false;
  app.add_option("--width", width, "channel width D [m]")->capture_default_str()->check(positive_up_to(1e3))
      ->group("Scene");
  app.add_option("--dx", dx, "particle spacing (default: the scene's) [m]")->check(positive_up_to(1))
      ->group("Numerics");
  app.add_option("--gamma", gamma, "mixed source weight in [0,1]")->capture_default_str()->group("Numerics");
  app.add_flag("--cold", cold, "start from zeros")->group("Solver");
  const std::string help = app.help();
  EXPECT_EQ(help.find("Options:"), std::string::npos) << help;
  const std::size_t general = help.find("\nGeneral:\n"), scene = help.find("\nScene:\n"),
                    numerics = help.find("\nNumerics:\n"), solver = help.find("\nSolver:\n");
  ASSERT_NE(general, std::string::npos) << help;
  EXPECT_LT(general, scene);
  EXPECT_LT(scene, numerics);
  EXPECT_LT(numerics, solver);
  EXPECT_NE(help.find("  --width=0.2 [m]                   channel width D; in (0, 1000]\n"), std::string::npos) << help;
  EXPECT_NE(help.find("  --dx FLOAT [m]                    particle spacing (default: the scene's); in (0, 1]\n"),
            std::string::npos)
      << help;
  EXPECT_NE(help.find("  --gamma=0.5                       mixed source weight in [0,1]\n"), std::string::npos)
      << help;  // "[0,1]" is no unit
  EXPECT_NE(help.find("  --cold                            start from zeros\n"), std::string::npos) << help;
  EXPECT_NE(help.find("  --version "), std::string::npos);
  EXPECT_NE(help.find("  --config "), std::string::npos);
}

namespace {

// What an app made of `text` given as --config: "" and the options set, or the error CLI11 reported.
struct ConfigRun {
  std::string error;
  double gamma = 0.01;
  std::string column = "classic";
  bool wet = false;
  std::vector<double> probes;
  std::string out;
};

ConfigRun read_config(const std::string& text) {
  // One file per process: ctest runs the ConfigFile tests side by side, and a shared name let one read another's file.
  const std::string path = testing::TempDir() + "sparsemps_config_" + std::to_string(getpid()) + ".toml";
  {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    std::fwrite(text.data(), 1, text.size(), f);
    std::fclose(f);
  }
  ConfigRun run;
  CLI::App app{"test"};
  add_config_option(app);
  app.add_option("--gamma", run.gamma)->group("Scene");
  app.add_option("--column", run.column)->group("Scene");
  app.add_flag("--wet-walls", run.wet)->group("Numerics");
  app.add_option("--probes", run.probes)->group("Run");
  app.add_option("--out", run.out)->group("Output");
  check_switches(app);
  std::vector<std::string> args{"app", "--config", path};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  try {
    app.parse(static_cast<int>(argv.size()), argv.data());
  } catch (const CLI::ParseError& e) {
    run.error = e.what();
  }
  return run;
}

}  // namespace

// The subset of TOML the apps write reads back: comments, blank lines, strings with escapes, switches, arrays, a
// byte-order mark.
TEST(ConfigFile, ReadsWhatTheAppsWrite) {
  const ConfigRun run = read_config(
      "\xEF\xBB\xBF# a comment\n\ngamma = 0.5  # trailing comment\ncolumn=\"seed \\\"x\\\"\"\nwet-walls=true\r\n"
      "probes=[0.2, 0.5,1e-1]\n");
  EXPECT_EQ(run.error, "");
  EXPECT_EQ(run.gamma, 0.5);
  EXPECT_EQ(run.column, "seed \"x\"");
  EXPECT_TRUE(run.wet);
  EXPECT_EQ(run.probes, (std::vector<double>{0.2, 0.5, 0.1}));
}

// TOML that is wrong, and keys the app does not take, are refused naming the line (toml++'s description of a syntax
// error, or ours): CLI11's own reader had kept the first of a repeated key, skipped malformed lines and taken an
// unterminated string literally.
TEST(ConfigFile, RefusesWhatIsNotAKeyValueLineNamingTheLine) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"gamma=0.5\ngamma=0.9\n", "line 2, column 7: Error while parsing key-value pair: cannot redefine existing"},
      {"gamma=0.5\ngamma\n", "line 2, column 6: Error while parsing key-value pair: expected '='"},
      {"gamma=0.5\n= 3\n", "line 2, column 1"},
      {"column=\"seed\n", "line 1, column 13: Error while parsing string"},
      {"column=seed\n", "line 1, column 8: Error while parsing value"},
      {"gamma=0.5 0.6\n", "line 1, column 11"},
      {"gamma=\n", "line 1, column 7: Error while parsing key-value pair: expected value"},
      {"[numerics]\ngamma=0.5\n", "line 2: 'gamma' is an option of [scene], not of [numerics]"},
      {"[scene]\ngamma=0.5\n[scene]\n", "line 3"},
      {"[physics]\ngamma=0.5\n", "line 1: [physics] is no group of this app's options ([general], [numerics], "},
      {"gamma=0.5\n[scene]\ngamma=0.6\n", "line 3: 'gamma' is set again (first on line 1); keep one"},
      {std::string("gamma=0.5\0\n", 11), "line 1, column 10"},
      {"wet-walls=2\n", "line 1: 'wet-walls' is a switch: its value is true or false"},
      {"gama=0.5\n", "line 1: 'gama' is not an option"},
      {"config=\"other.toml\"\n", "line 1: 'config' is not an option"},
      {"probes=[0.2, 0.5\n", "line 1, column 18: Error while parsing array"},
      {"column=\"a\\qb\"\n", "unknown escape sequence '\\q'"},
      {"gamma=1979-05-27\n", "line 1: the value of 'gamma' must be a number"},
  };
  for (const auto& [text, expected] : cases) {
    const ConfigRun run = read_config(text);
    EXPECT_NE(run.error.find(expected), std::string::npos) << "file: " << text << "\nerror: " << run.error;
  }
}

// The files the apps write now: a [section] per --help group, paths relative to the file's folder, TOML's own
// forms of numbers and strings.
TEST(ConfigFile, SectionsAsTheHelpGroupsAndPathsRelativeToTheFile) {
  const ConfigRun run = read_config(
      "# units as comments\n[scene]\ngamma = 5e-1  # [1]\ncolumn = 'seed'\n\n[numerics]\nwet-walls = true\n"
      "[run]\nprobes = [0.2, 1]\n[output]\nout = \"runs/x\"\n");
  EXPECT_EQ(run.error, "");
  EXPECT_EQ(run.gamma, 0.5);
  EXPECT_EQ(run.column, "seed");
  EXPECT_TRUE(run.wet);
  EXPECT_EQ(run.probes, (std::vector<double>{0.2, 1.0}));
  EXPECT_EQ(run.out, (std::filesystem::path(testing::TempDir()) / "runs/x").lexically_normal().string());
  // A float round-trips to its bits (17 digits handed to CLI11).
  EXPECT_EQ(read_config("gamma = 0.1\n").gamma, 0.1);
  EXPECT_EQ(read_config("gamma = 0.30000000000000004\n").gamma, 0.1 + 0.2);
}

// A switch takes true or false on the command line too: --wet-walls=2 was taken as on.
TEST(ConfigFile, SwitchesOnTheCommandLineTakeTrueOrFalseOnly) {
  for (const auto& [arg, ok, value] : std::vector<std::tuple<std::string, bool, bool>>{
           {"--wet-walls", true, true}, {"--wet-walls=false", true, false}, {"--wet-walls=2", false, false},
           {"--wet-walls=yes", false, false}}) {
    bool wet = false;
    CLI::App app{"test"};
    app.add_flag("--wet-walls", wet);
    check_switches(app);
    std::vector<std::string> args{"app", arg};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    bool parsed = true;
    try {
      app.parse(static_cast<int>(argv.size()), argv.data());
    } catch (const CLI::ParseError&) {
      parsed = false;
    }
    EXPECT_EQ(parsed, ok) << arg;
    if (ok) {
      EXPECT_EQ(wet, value) << arg;
    }
  }
}

// parse_options refuses '=' and nothing after a switch, which CLI11 took as on (--wet-walls=).
TEST(ConfigFile, ASwitchGivenEqualsAndNothingIsRefused) {
  bool wet = false;
  CLI::App app{"test"};
  app.add_flag("--wet-walls", wet);
  std::vector<std::string> args{"app", "--wet-walls="};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  const auto status = parse_options(app, static_cast<int>(argv.size()), argv.data(), true);
  ASSERT_TRUE(status.has_value());
  EXPECT_NE(*status, 0);
  EXPECT_FALSE(wet);
}

// --config's path is checked before the file is opened: a FIFO would block the open and /dev/zero never end.
TEST(ConfigFile, AConfigPathThatIsNotASmallRegularFileIsRefusedBeforeItIsOpened) {
  const std::string dir = testing::TempDir();
  const std::string fifo = dir + "sparsemps_config_fifo", big = dir + "sparsemps_config_big.toml";
  std::remove(fifo.c_str());
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  {
    std::FILE* f = std::fopen(big.c_str(), "wb");
    const std::string line(1024, '#');
    for (int k = 0; k < 1100; ++k) std::fprintf(f, "%s\n", line.c_str());
    std::fclose(f);
  }
  for (const auto& [path, said] : std::vector<std::pair<std::string, std::string>>{
           {"", "the path is empty"}, {"/dev/zero", "is not a regular file"}, {fifo, "is not a regular file"},
           {dir + "no_such_config.toml", "exists"}, {big, "a config file is a few kB"}}) {
    CLI::App app{"test"};
    add_config_option(app);
    std::vector<std::string> args{"app", "--config", path};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    std::string error;
    try {
      app.parse(static_cast<int>(argv.size()), argv.data());
    } catch (const CLI::ParseError& e) {
      error = e.what();
    }
    EXPECT_NE(error.find(said), std::string::npos) << path << ": " << error;
  }
  std::remove(fifo.c_str());
  std::remove(big.c_str());
}

// The randomized whole-lab test: from one 64-bit seed (std::mt19937_64), a small lab of every
// drive family (UIM342 and UC57 on a simulated CAN bus, ADAM Modbus RTU on an RS485 simserial
// line, UIM242 behind a UIM2501 gateway on an RS232 simserial line) and a sequence of requests of
// 2-3 concurrent clients; a reference model predicts each outcome (terminal status and error code
// of the README's list, final position in counts, which axes end enabled) and the runner checks the
// prediction and the invariants (one terminal reply per request within its timeout, no axis moving
// after a stop, every process heartbeating) after every step. A failing case is shrunk (delta
// debugging over the steps, then simpler values, then fewer drives) and printed as ready-to-paste
// C++ (a YAML text and a step list for run_case()).
//
// Thread contract: single-threaded (the test's thread). run_case() blocks while it starts the
// processes of a lab (motion-sim, one motion-gateway per bus, motion-coordinator on their own LCM
// URL), runs the steps and kills the processes before it returns.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <vector>

namespace motion::random_lab {

// --------------------------------------------------------------------------- the lab

struct DriveSpec {
  std::string family;  // uim342, uc57, adam-modbus, uim242
  std::string bus;     // can0, rs485, rs232
  int node_id = 0;
  int group_id = 0;  // uim342 only, 0 = none
};

struct AxisSpec {
  std::string name;
  DriveSpec drive;
  double steps_per_unit = 1.0;
  double min = 0, max = 0, velocity = 0, acceleration = 0;
  bool homing = false;  // homing configured (else none): see home_input
  double home_offset = 0;
  int home_input = 0;  // 0: `current-position` (origin where it stands + offset); 1..3: `switch`
                       // on this input (UIM342), searched at home_velocity (user units/s, < 0:
                       // toward min), the simulated switch edge half-way to the limit
  double home_velocity = 0;
};

struct LabSpec {
  int can_bitrate = 1000000;
  int rs485_baud = 115200;
  int rs232_baud = 57600;
  std::string rs485_parity = "none";  // none, even, odd
  // security: {mode: enforce}: the coordinator accepts signed requests only, its gateway commands
  // are signed; the runner's clients sign with admin keys of their own.
  bool security = false;
  // simulation.serial_link: what motion-sim makes the serial lines, "pty" or "socket".
  std::string serial_link = "pty";
  std::vector<AxisSpec> axes;
  [[nodiscard]] std::string yaml() const;
  [[nodiscard]] const AxisSpec* find(const std::string& axis) const;
};

struct GenOptions {
  int min_drives = 2;
  int max_drives = 5;
  bool parity = false;  // also even/odd parity on the RS485 line
  bool chaos = false;   // also kFault steps (tools/chaos)
};

LabSpec generate_lab(std::mt19937_64& rng, const GenOptions& options);

// --------------------------------------------------------------------------- the steps

enum class Op : std::int8_t {
  kRequest,   // one request of `client`, awaited to its terminal reply
  kJogStop,   // `client` jogs `axes` at `values`, then `other_client` sends `stop_kind` to them
  kConflict,  // `client` starts a slow move of `axes` to `values` (absolute); while it runs,
              // `other_client` sends `second_kind` on `second_axes`; then `other_client` sends
              // `stop_kind` to `axes`
  kFault,     // chaos: `client` moves `axes` to `values` (absolute); 200 ms later the simulator
              // injects `fault` (a sim_control_t action, `fault_value`) on the drive of
              // `second_axes[0]` (or its bus) for 1 s; then the fault is cleared, the lab
              // recovers (every axis online, reset, enabled) and the model reads the lab back
};

struct Step {
  Op op = Op::kRequest;
  int client = 0;
  std::int8_t kind = 0;  // request_t kind
  std::vector<std::string> axes;
  std::vector<double> values;
  double velocity_scale = 0;
  double acceleration_scale = 0;
  std::int32_t timeout_ms = 0;
  std::int32_t output_mask = 0;
  std::int32_t output_value = 0;
  int other_client = 0;
  std::int8_t stop_kind = 0;
  std::int8_t second_kind = 0;
  std::vector<std::string> second_axes;
  std::vector<double> second_values;
  std::int8_t fault = 0;  // kFault: sim_control_t action
  std::int32_t fault_value = 0;

  [[nodiscard]] std::string cpp() const;  // a C++ initializer of this step
};

std::string describe(const Step& step);
const char* fault_name(std::int8_t action);  // a sim_control_t action by its constant's name

// --------------------------------------------------------------------------- the reference model

// What the model knows of one axis.
struct AxisModel {
  bool enabled = false;
  std::optional<std::int64_t> counts;  // nullopt: not predictable (after a jog or a stop); read back
  double commanded = 0;                // the base of a relative move, user units
  bool at_target = false;              // `commanded` is a finished move's target (the coordinator
                                       // keeps it while the axis stands within one count of it)
};

// Prediction of one request's terminal reply.
struct Outcome {
  std::vector<std::int8_t> statuses;  // acceptable terminal statuses
  std::vector<std::int32_t> codes;    // acceptable error codes (of the first status that is not DONE)
  [[nodiscard]] bool done() const { return statuses.size() == 1 && statuses[0] == 4; }
  [[nodiscard]] std::string text() const;
};

class Model {
 public:
  explicit Model(const LabSpec& lab);
  // Predicts `kind` on `axes` with `values`, then applies it to the state when `apply` (the
  // request's outcome is the predicted one). Positions of stopped/jogged axes become unknown.
  Outcome request(std::int8_t kind, const std::vector<std::string>& axes, const std::vector<double>& values,
                  double velocity_scale, double acceleration_scale, std::int32_t timeout_ms, bool apply);
  // An axis's position is read back (after a jog or a stop).
  void observe(const std::string& axis, std::int64_t counts);
  // Marks axes as moving for another request (conflict steps).
  void set_busy(const std::vector<std::string>& axes, bool busy);
  [[nodiscard]] const std::map<std::string, AxisModel>& axes() const { return axes_; }
  AxisModel& axis(const std::string& name) { return axes_.at(name); }
  [[nodiscard]] const LabSpec& lab() const { return lab_; }
  [[nodiscard]] std::int64_t counts_of(const std::string& axis, double units) const;

 private:
  LabSpec lab_;
  std::map<std::string, AxisModel> axes_;
  std::map<std::string, bool> busy_;
};

// The slowest velocity/acceleration scale at which a move of `axes` to `targets` ends within
// `seconds` (an axis of unknown position is taken at its farther limit).
double scale_for(const LabSpec& lab, const Model& model, const std::vector<std::string>& axes,
                 const std::vector<double>& targets, double seconds);
std::vector<Step> generate_steps(std::mt19937_64& rng, const LabSpec& lab, int count, bool chaos = false);

// --------------------------------------------------------------------------- running and shrinking

struct RunResult {
  bool ok = true;
  int failed_step = -1;  // index of the step whose check failed, -1 = lab start-up / none
  std::string failure;   // what was wrong (prediction vs observation)
  std::string log;       // one line per step
  int steps_run = 0;
  int requests = 0;       // requests sent (each checked for one terminal reply)
  int faults = 0;         // faults injected (kFault steps run)
  int faults_biting = 0;  // of which the move during the fault did not end DONE
};

struct RunOptions {
  bool verbose = false;                // print each step as it runs
  bool print_logs_on_failure = false;  // the processes' logs (ADD_FAILURE first so the group prints them)
  int salt = 0;                        // varies the LCM port between runs of one process
};

RunResult run_case(const LabSpec& lab, const std::vector<Step>& steps, const RunOptions& options = {});

struct Shrunk {
  LabSpec lab;
  std::vector<Step> steps;
  RunResult result;
  int runs = 0;
};

// Delta debugging: drops chunks of steps, then single steps, then simplifies values and drops
// drives no remaining step uses, while the case still fails (any failure). Stops after `budget`.
Shrunk shrink(const LabSpec& lab, const std::vector<Step>& steps, const RunResult& first, std::chrono::seconds budget);

// Ready-to-paste C++ for a regression test.
std::string reproduction(const LabSpec& lab, const std::vector<Step>& steps, const RunResult& result,
                         std::uint64_t seed);

}  // namespace motion::random_lab

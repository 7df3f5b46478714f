// The daemon's configuration as plain structs. Filled and validated by config/load.hpp at
// start-up; read-only afterwards (any thread may read it). Every field gives its unit; defaults
// are the values a field takes when the JSON omits it, except fields marked "required", which
// the JSON must give (their initializers are placeholders). A loaded Config satisfies every rule
// written here. The JSON reference is config/README.md.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace hvac_twin::config {

enum class RegisterKind { kHolding, kInput };  // function code 0x03 / 0x04
enum class ValueType { kInt16, kUint16, kInt32, kUint32, kFloat32 };

// Byte order of a value over its registers, A = most significant byte. Modbus sends each register
// big-endian, so 16-bit values are AB (or BA when the device swaps bytes). For 32-bit values:
// ABCD = high word first ("big-endian"), CDAB = low word first ("word swap"), BADC = bytes
// swapped in each word, DCBA = fully little-endian. For 16-bit types only ABCD and BADC are valid
// (meaning AB and BA).
enum class WordOrder { kABCD, kCDAB, kBADC, kDCBA };

// What a point means to the model.
//  kMeasured:    a model output y; fused by the filter when its quality is GOOD.
//  kInput:       an actuator input u the controller sets (compressor speed, valve opening, ...).
//  kDisturbance: a known disturbance u (outdoor air temperature, ...). Same use as kInput.
enum class PointRole { kMeasured, kInput, kDisturbance };

struct PointConfig {
  std::string name;                            // required; unique within the unit; [A-Za-z0-9_]+
  RegisterKind kind = RegisterKind::kHolding;  // JSON "register": "holding" | "input"
  std::uint16_t address = 0;  // required; 0-based protocol address of the first register; the
                              // registers of points of one kind in a unit do not overlap
  ValueType type = ValueType::kUint16;      // JSON "int16"|"uint16"|"int32"|"uint32"|"float32"
  WordOrder word_order = WordOrder::kABCD;  // JSON "ABCD"|"CDAB"|"BADC"|"DCBA"
  double scale = 1.0;                       // engineering value = raw * scale + offset; != 0
  double offset = 0.0;                      // [unit]
  std::string unit;              // required; engineering unit of the decoded value: a name of
                                 // config/units.hpp that converts to the signal's unit
  double range_min = 0.0;        // required; physical range [unit], min < max; outside it the point
  double range_max = 0.0;        //   is OUT_OF_RANGE (JSON "range": [min, max])
  double stale_after_s = 10.0;   // a GOOD value older than this is STALE [s, wall]; > poll period
  double stuck_after_s = 300.0;  // measured point: a raw value unchanged this long while the
                                 // model moved it by 4 sigma of its noise is STUCK, not fused
                                 // [s, model]; 0: never (a signal legitimately constant)
  PointRole role = PointRole::kMeasured;
  std::string signal;  // required; the model output (measured) or model input (input/disturbance)
                       // it feeds; each model input is fed by at most one point
};

struct ModbusDeviceConfig {
  std::string host = "127.0.0.1";       // IPv4 address or host name of the Modbus TCP server
  std::uint16_t port = 502;             // TCP port
  int unit_id = 1;                      // Modbus unit identifier, 0..255 (checked in every reply)
  double response_timeout_s = 0.4;      // per request; below half the poll period [s]
  double byte_timeout_s = 0.1;          // between bytes of one reply; <= response timeout [s]
  double poll_period_s = 1.0;           // how often every point is read [s, wall]
  double backoff_initial_s = 0.5;       // first reconnect delay after a transport error;
                                        //   <= backoff_max_s [s]
  double backoff_max_s = 5.0;           // reconnect delay cap; jittered exponential in between [s]
  int max_registers_per_request = 125;  // contiguous points are grouped up to this many registers
};

struct ModelConfig {
  std::string type;                          // required; a model of the catalog, e.g. "zone_rc"
  std::map<std::string, double> parameters;  // name -> value in the parameter's unit; omitted
                                             // parameters take the model's defaults
  std::string file;                          // type "fmu": the FMU's absolute path (JSON "fmu")
};

// Which filter runs the unit (JSON "ekf" | "constrained_ekf" | "constrained_enkf").
//  kEkf:             extended Kalman filter, exact F from CVODES sensitivities
//  kConstrainedEkf:  the same with the QP-constrained update and covariance truncation
//  kConstrainedEnkf: ensemble Kalman filter, members projected onto the constraints
enum class EstimatorType { kEkf, kConstrainedEkf, kConstrainedEnkf };

// Refrigerant leak detection (models with an augmented "leak_rate" state): one-sided CUSUMs on
// the standardised leak-rate estimate and on the charge deficit against references learnt per
// compressor-speed band, one decision per interval_s of judgeable operation.
struct LeakDetectionConfig {
  double interval_s = 1800.0;                 // judgeable model time per decision [s]
  double design_shift_sigma = 2.0;            // the leak size (in sigma) found quickest
  double false_alarm_interval_days = 3650.0;  // designed mean time between false alarms [days]
  double warm_up_s = 3600.0;                  // no decision this long after a (cold) start [s]
  double startup_s = 900.0;                   // held this long after a compressor start [s]
  double min_compressor_speed_hz = 5.0;       // below: the compressor is off [Hz]
  double max_starts_per_hour = 3.0;           // more starts in the last hour: cycling, held
  double leak_sigma_floor = 0.1;              // smallest leak-rate sigma divided by [g/h]
  // The leak-rate estimate's in-control level: only a rate beyond it accumulates [g/h].
  double leak_rate_allowance = 3.0;
  // The charge estimate's in-control wander within a speed band, as a fraction of the
  // nameplate charge (0: the charge-deficit statistic off).
  double charge_allowance = 0.02;
  // The in-control standard deviation of an interval's charge deficit (beyond the filter's own
  // sigma), as a fraction of the nameplate charge: the charge statistic's scale (0: the allowance).
  double charge_noise = 0.006;
  double reference_s = 64800.0;     // judgeable time the reference charges are learnt over [s]
  double reference_band_hz = 20.0;  // width of the compressor-speed bands [Hz]
};

struct EstimatorConfig {
  EstimatorType type = EstimatorType::kConstrainedEkf;
  int ensemble_members = 32;  // constrained_enkf: ensemble size, 4..1000
  int threads = 2;            // constrained_enkf: worker threads (the cycle thread included)
  double period_s = 10.0;     // model time advanced per cycle [s]
  double deadline_s = 1.0;    // wall-time budget of one cycle [s]; an overrun degrades the cycle;
                              // <= period_s / runtime.time_scale and < runtime.hang_timeout_s
  double nis_gate = 10.83;    // per-measurement innovation gate, chi-square(1) at alpha = 1e-3
  double robust_threshold = 2.0;       // Huber weight beyond this many innovation sigmas; 0 off
  int max_consecutive_rejections = 5;  // this many gate rejections in a row flag a point faulty;
                                       // most points rejected this often resets the covariance
  double settle_s = 0.0;  // model seconds the model runs at the first inputs before filtering
                          // starts from its initial guess [s]
  // After a cold start (or a restart from the measured conditions) the augmented states (slow
  // parameters, disturbances) are held at their priors for this many model seconds, while the
  // physical states converge onto the measurements [s].
  double parameter_hold_s = 600.0;
  // Then their updates' gain rises from 0 to full over this many model seconds (a partial
  // update: est::StatePhases, "release"); 0 releases them at once [s].
  double parameter_release_s = 120.0;
  int checkpoint_every_cycles = 60;  // the whole filter state is saved to state_directory every
                                     // this many cycles; 0: never (always a cold start)
  // A checkpoint written longer ago than this resumes only the unit's properties (the model's
  // persistent states: charge, leak rate, fouling) with their covariance; the operating state
  // is re-settled from the measured conditions, converging again. 0: any age resumes whole [s].
  double checkpoint_max_age_s = 900.0;
  // The consistency monitor's window (mean NIS against its chi-square band) [s, model time]:
  // round(consistency_window_s / period_s) cycles, at least 30; that ratio at most 100000.
  double consistency_window_s = 3600.0;
  // Bounded covariance matching of each measured point's noise over that window
  // (daemon/estimation/noise_adapter.hpp): the filter is told measurement_noise^2 times a factor
  // in [adaptive_noise_min, adaptive_noise_max] that the innovations estimate. Both 1: off.
  // Not learnt while the filter has lost track. Default 1:9, inflation only (README, "Adaptive
  // measurement noise": no alarm in 7 normal days, the 10 %/day leak found sooner and the
  // 2 %/day one an hour later (within its aim), the heat-flow and charge errors lower, and a
  // biased sensor gated in 3.2 % of cycles instead of 22.5 %).
  double adaptive_noise_min = 1.0;  // (0, 1]
  double adaptive_noise_max = 9.0;  // [1, 100]
  LeakDetectionConfig leak_detection;
  // Per state, in the state's unit; a state not listed takes the model's StateInfo default
  // (process_noise, initial, initial_std). Names are states of the unit's model.
  std::map<std::string, double> process_noise;  // state -> random-walk intensity, >= 0
                                                // [unit/sqrt(s)]
  std::map<std::string, double> initial_state;  // state -> initial estimate [unit], in its bounds
  std::map<std::string, double> initial_std;    // state -> initial standard deviation [unit], > 0
  // Required: exactly the model outputs that some point of the unit measures -> standard
  // deviation of the measurement [the output's unit, not the point's], > 0.
  std::map<std::string, double> measurement_noise;
};

struct UnitConfig {
  std::string id;  // required; unique on the site; [A-Za-z0-9_-]+; used as a DDS key
  ModbusDeviceConfig modbus;
  std::vector<PointConfig> points;  // required; at least one measured point, every model input
                                    // without a default fed by one input/disturbance point
  ModelConfig model;                // required
  EstimatorConfig estimator;        // required (for measurement_noise)
  // A calibration file (config/calibration_file.hpp) as written: absolute, or relative to the
  // configuration file's directory. load_config_file() applies it to model and estimator.
  std::string calibration;
};

// DDS Security with Cyclone DDS's built-in plugins: authentication by X.509 certificates
// (DDS:Auth:PKI-DH), access control by signed governance and permissions documents
// (DDS:Access:Permissions), encryption with AES-GCM (DDS:Crypto:AES-GCM-GMAC). What is protected
// (discovery, liveliness, data; sign or encrypt) is the governance document's decision.
// Every field is required and is a file path: absolute, or "${CREDENTIALS_DIRECTORY}/<name>" for
// a file systemd's LoadCredential= provides (resolved from the environment at start-up). Paths
// are 1..4096 characters without control characters or any of < > & $ \ (other than that one
// leading variable). The loader does not touch the files; the daemon checks at start-up that each
// is readable and stops with an error naming the field if one is not.
struct DdsSecurityConfig {
  std::string identity_ca;           // PEM certificate of the CA that issues identities
  std::string identity_certificate;  // PEM certificate of this participant, issued by identity_ca
  std::string private_key;           // PEM private key of identity_certificate (unencrypted)
  std::string permissions_ca;        // PEM certificate of the CA that signs the two documents
  std::string governance;            // S/MIME-signed governance document (usually *.p7s)
  std::string permissions;           // S/MIME-signed permissions document with a grant for the
                                     // subject of identity_certificate
};

struct DdsConfig {
  int domain_id = 0;                            // 0..232
  std::string interface = "lo";                 // network interface Cyclone DDS is pinned to
  bool allow_multicast = false;                 // multicast discovery (off: unicast to `peers`)
  std::vector<std::string> peers{"127.0.0.1"};  // unicast discovery peers; >= 1 without multicast
  std::string topic_prefix = "hvac_twin";       // topics are "<prefix>/<topic>"; [A-Za-z0-9_]+
  std::optional<DdsSecurityConfig> security;    // JSON "security"; absent: no DDS Security
};

struct RuntimeConfig {
  // Model seconds per wall second. 1 in production; above 1 only against a simulator that runs
  // with the same --time-scale (tests and the demo). The cycle runs every period_s / time_scale
  // wall seconds and always advances the model by period_s.
  double time_scale = 1.0;
  // A cycle running longer than this many wall seconds is "hung": logged, health reports it,
  // and with hang_exit the process exits (status 70) so its supervisor restarts it [s].
  double hang_timeout_s = 30.0;
  bool hang_exit = true;
  int overruns_before_watchdog_stop = 3;  // consecutive overruns after which WATCHDOG=1 stops
  std::string log_level = "info";         // trace|debug|info|warn|error
  // Per unit, the disk its recording of every cycle's point snapshot may use, in
  // <state_directory>/recordings (hvac-twin-replay reads it) [MiB]; 0: no recording.
  std::int64_t recording_budget_mib = 0;
};

struct Config {
  std::string site_id;  // required; [A-Za-z0-9_-]+; DDS key of every sample
  // Checkpoints. Absolute, or relative to the daemon's working directory at start-up (not to the
  // configuration file). Not checked against the file system by the loader.
  std::string state_directory = "/var/lib/hvac-twin";
  std::vector<UnitConfig> units;  // required; at least one
  DdsConfig dds;
  RuntimeConfig runtime;
};

}  // namespace hvac_twin::config

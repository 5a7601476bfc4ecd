// fig3_reference: the paper's Fig. 3 from a recorded push. The ankle torque τ_v^ankle about one
// axis of the virtual stance foot, read from the BALANCE_STATUS messages of a log (a trial with the
// ankle strategy alone: the torque the push demands of the ankles), is fed open loop to the CAM
// reference generator (reference_gen's library, (23)-(27)) once per α at the configured β, and once
// per β at the configured α. The CSV it writes is what tools/plots/plot_fig3.py draws.
//
//   fig3_reference LOG OUT.csv [--robot toro] [--axis y] [--alphas 0.7,0.8,0.9] [--betas 0.3,0.4,0.5]
//
// Open loop: the generated CAM does not change the torque it is fed (in the closed loop it
// lowers it), and the posture counts as converged, so phase 3 lasts the configured minimum.
#include <humanoid/balance_status_t.hpp>

#include <cstdio>
#include <fstream>
#include <limits>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <vector>

#include "hpr/common/args.hpp"
#include "hpr/common/config.hpp"
#include "hpr/experiments/trial.hpp"
#include "hpr/msg/log_check.hpp"
#include "hpr/reference_gen/generator.hpp"

namespace {

using hpr::reference_gen::AxisGenerator;
using hpr::reference_gen::AxisParams;
using hpr::reference_gen::GeneratorConfig;

void usage(std::FILE* out) {
  std::fputs(R"(usage: fig3_reference LOG OUT.csv [options]

The CAM reference generator run open loop on the ankle torque recorded in LOG (BALANCE_STATUS),
for several alpha and beta (the paper's Fig. 3); plot with tools/plots/plot_fig3.py OUT.csv OUT.png.

  --robot R        robot configuration whose reference_gen section gives the other parameters
                   and the default alpha and beta of the axis (default toro)
  --axis A         x, y or z of the virtual stance foot (default y: sagittal pushes)
  --alphas LIST    alpha values, each at the configured beta (default 0.7,0.8,0.9)
  --betas LIST     beta values, each at the configured alpha (default 0.3,0.4,0.5)
)",
             out);
}

struct Sample {
  double t, tau_ankle, tau_min, tau_max;
};

/// τ_v^ankle and its limits about `axis` from every BALANCE_STATUS of the log, in log order.
std::vector<Sample> read_balance(const std::string& path, int axis) {
  lcm::LogFile log(path, "r");
  if (!log.good()) throw std::runtime_error("cannot open the log " + path);
  std::vector<Sample> out;
  long undecodable = 0;
  while (const lcm::LogEvent* e = log.readNextEvent()) {
    if (hpr::msg::type_of_channel(e->channel) != "humanoid.balance_status_t") continue;
    if (!hpr::msg::check_message(e->channel, e->data, e->datalen).empty()) {
      ++undecodable;
      continue;
    }
    humanoid::balance_status_t m;
    m.decode(e->data, 0, static_cast<int>(e->datalen));
    out.push_back({static_cast<double>(m.utime) * 1e-6, m.tau_ankle_V[axis], m.tau_min_V[axis], m.tau_max_V[axis]});
  }
  if (undecodable > 0) std::fprintf(stderr, "fig3_reference: %ld BALANCE_STATUS events did not decode (skipped)\n", undecodable);
  if (out.size() < 2) throw std::runtime_error("the log " + path + " holds fewer than two BALANCE_STATUS messages");
  return out;
}

void run(std::ofstream& csv, const char* series, const std::vector<Sample>& trace, AxisParams p, const GeneratorConfig& cfg) {
  AxisGenerator g(p);
  for (size_t k = 0; k < trace.size(); ++k) {
    const Sample& s = trace[k];
    const double dt = k > 0 ? s.t - trace[k - 1].t : trace[1].t - trace[0].t;
    g.step(s.t, dt, s.tau_ankle, s.tau_min, s.tau_max, true, cfg);
    csv << series << ',' << p.alpha << ',' << p.beta << ',' << s.t << ',' << s.tau_ankle << ',' << s.tau_min << ','
        << s.tau_max << ',' << g.threshold() << ',' << g.l()
        << ',' << g.ldot() << ',' << static_cast<int>(g.phase()) << '\n';
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::string log_path, csv_path, robot = "toro";
  int axis = 1;
  std::vector<double> alphas = {0.7, 0.8, 0.9}, betas = {0.3, 0.4, 0.5};
  const auto usage_error = hpr::read_command_line(
      argc, argv, "fig3_reference", usage,
      [&](hpr::ArgReader& args) {
        if (args.is("--robot")) {
          robot = args.value();
        } else if (args.is("--axis")) {
          const std::string a = args.value();
          if (a != "x" && a != "y" && a != "z") throw hpr::UsageError("--axis: '" + a + "' is not x, y or z");
          axis = a[0] - 'x';
        } else if (args.is("--alphas") || args.is("--betas")) {
          const bool is_alpha = args.is("--alphas");
          std::vector<double>& v = is_alpha ? alphas : betas;
          v.clear();
          for (const auto& s : args.list()) {
            const double x = hpr::parse_number(s, is_alpha ? "--alphas" : "--betas");
            if (!(x > 0 && x <= 1)) throw hpr::UsageError(std::string(is_alpha ? "--alphas" : "--betas") + ": " + s + " is not in (0, 1]");
            v.push_back(x);
          }
        } else if (args.positional() && log_path.empty()) {
          log_path = args.current();
        } else if (args.positional() && csv_path.empty()) {
          csv_path = args.current();
        } else {
          args.unknown();
        }
      },
      [&] {
        if (csv_path.empty()) throw hpr::UsageError("need LOG and OUT.csv");
      });
  if (usage_error) return *usage_error;
  try {
    const hpr::Config cfg = hpr::Config::load(hpr::experiments::find_config(robot));
    const GeneratorConfig gen = GeneratorConfig::load(cfg.section("reference_gen"));
    const AxisParams configured = gen.axes[static_cast<size_t>(axis)];
    const std::vector<Sample> trace = read_balance(log_path, axis);
    std::ofstream csv(csv_path);
    if (!csv) throw std::runtime_error("cannot write " + csv_path);
    csv.precision(std::numeric_limits<double>::max_digits10);
    csv << "series,alpha,beta,t,tau_ankle,tau_min,tau_max,tau_thres,l_ref,ldot_ref,phase\n";
    for (const double a : alphas) run(csv, "alpha", trace, {a, configured.beta}, gen);
    for (const double b : betas) run(csv, "beta", trace, {configured.alpha, b}, gen);
    std::printf("%s: %zu samples of tau_ankle about %c, %zu alphas at beta %.2f, %zu betas at alpha %.2f\n", csv_path.c_str(),
                trace.size(), static_cast<char>('x' + axis), alphas.size(), configured.beta, betas.size(), configured.alpha);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fig3_reference: %s\n", e.what());
    return 1;
  }
  return 0;
}

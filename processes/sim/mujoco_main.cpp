// sim_mujoco: the MuJoCo simulation of the robot, speaking the same LCM channels as sim_bullet.
#include "sim_node.hpp"

int main(int argc, char** argv) { return hpr::sim::run_sim_process(argc, argv, hpr::sim::EngineKind::kMujoco); }

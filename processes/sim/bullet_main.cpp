// sim_bullet: the Bullet simulation of the robot, speaking the same LCM channels as the hardware.
#include "sim_node.hpp"

int main(int argc, char** argv) { return hpr::sim::run_sim_process(argc, argv, hpr::sim::EngineKind::kBullet); }

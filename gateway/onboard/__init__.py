"""PX4's onboard services: the logger (ULog) and its files, the MAVLink shell's interpreter."""

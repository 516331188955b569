"""PX4's onboard services: the logger (ULog) and what serves its files."""

"""Launch files, parameters, recording, plots and the phri command."""

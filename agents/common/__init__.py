"""What every part of ``agents`` shares: config loading, seed ranges, paths, machine facts and table writers."""

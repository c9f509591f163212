"""The robust optimiser: log-linear programs per operation, solved by HiGHS or Clarabel."""

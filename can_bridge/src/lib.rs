//! CAN motor bridge (issue 4).

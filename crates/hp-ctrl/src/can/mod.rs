//! CAN codec: frames as the DBC (`can/hpctl.dbc`) defines them, with
//! end-to-end protection. Being written.

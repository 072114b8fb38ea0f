//! # plugin-yaml-machines: an example postpro plugin with definitions only
//!
//! A shop's two machines as one library, without any code of their own: a table-table trunnion
//! mill (`shop-trunnion-ac`) and a 4-axis VMC with an A rotary table (`shop-vmc-a4`). Both use
//! the generic kinematic chain of their definitions (`solver: generic`). Shipping definitions
//! in a plugin rather than as YAML files keeps them together with the shop's other machines
//! and out of reach of accidental edits on the shop floor.

postpro_plugin_api::export_plugin! {
    name: "plugin-yaml-machines",
    machines: ["machines/shop-trunnion-ac.yaml", "machines/shop-vmc-a4.yaml"],
    kinematics: [],
}

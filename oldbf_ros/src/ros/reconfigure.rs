//! dynamic_reconfigure for oldbf_node, on the real protocol, so Debian's
//! Python client (`dynamic_reconfigure.client`, `dynparam`) and
//! rqt_reconfigure can read and set the parameters of
//! [`crate::reconfigure::RECONFIGURABLE`]:
//!
//! * `~parameter_descriptions` (dynamic_reconfigure/ConfigDescription,
//!   latched): one group per YAML section under the root group `Default`,
//!   each parameter with its type, description, default, min and max;
//! * `~parameter_updates` (dynamic_reconfigure/Config, latched): the running
//!   values, after every request;
//! * `~set_parameters` (dynamic_reconfigure/Reconfigure): a partial or full
//!   configuration; the answer is the running configuration after it.
//!
//! Parameters are named by their dotted YAML key (`barrier.d_safe_m`). An
//! accepted change is also written to the parameter server where the YAML
//! file loads it (`~barrier/d_safe_m`), as the C++ and Python servers do, so
//! `rosparam get` shows it and a respawned node starts with it.
//!
//! A refused request (out of range, a cross-key rule, an unknown key) changes
//! nothing: the answer and `~parameter_updates` carry the running values, and
//! the reason, worded as for the YAML file, goes to the log (and /rosout).
//! The reference servers clamp instead of refusing, and their clients take
//! the answer as the truth; a service error would make rqt_reconfigure's
//! update thread stop for good, so it is not used.

use super::msg::dynamic_reconfigure::{
    BoolParameter, Config, ConfigDescription, DoubleParameter, Group, GroupState, IntParameter, ParamDescription,
    Reconfigure, ReconfigureRes,
};
use super::RosError;
use crate::reconfigure::{Kind, ReconfigureError, Spec, Value};

/// Name and id of the root group (the reference implementations' `Default`, id 0).
const ROOT: (&str, i32) = ("Default", 0);

/// The group of each section, in the order sections first appear: ids from 1.
fn sections(specs: &[Spec]) -> Vec<&'static str> {
    let mut out: Vec<&'static str> = Vec::new();
    for s in specs {
        if !out.contains(&s.section()) {
            out.push(s.section());
        }
    }
    out
}

fn group_states(specs: &[Spec]) -> Vec<GroupState> {
    let mut groups = vec![GroupState {
        name: ROOT.0.into(),
        state: true,
        id: ROOT.1,
        parent: 0,
    }];
    for (i, name) in sections(specs).into_iter().enumerate() {
        groups.push(GroupState {
            name: name.into(),
            state: true,
            id: i as i32 + 1,
            parent: ROOT.1,
        });
    }
    groups
}

fn push(config: &mut Config, name: &str, value: Value) {
    let name = name.to_string();
    match value {
        Value::Double(value) => config.doubles.push(DoubleParameter { name, value }),
        Value::Int(value) => config.ints.push(IntParameter { name, value }),
        Value::Bool(value) => config.bools.push(BoolParameter { name, value }),
    }
}

/// A Config message of `values`, with the group states when `with_groups`.
pub fn config_msg(values: &[(&str, Value)], specs: &[Spec], with_groups: bool) -> Config {
    let mut c = Config::default();
    for &(name, value) in values {
        push(&mut c, name, value);
    }
    if with_groups {
        c.groups = group_states(specs);
    }
    c
}

/// The ConfigDescription of `specs`.
pub fn description_msg(specs: &[Spec]) -> ConfigDescription {
    let mut groups = vec![Group {
        name: ROOT.0.into(),
        type_: String::new(),
        parameters: Vec::new(),
        parent: 0,
        id: ROOT.1,
    }];
    for (i, section) in sections(specs).into_iter().enumerate() {
        groups.push(Group {
            name: section.into(),
            type_: String::new(),
            parameters: specs
                .iter()
                .filter(|s| s.section() == section)
                .map(|s| ParamDescription {
                    name: s.key.into(),
                    type_: s.kind.as_str().into(),
                    level: 0,
                    description: s.description.into(),
                    edit_method: String::new(),
                })
                .collect(),
            parent: ROOT.1,
            id: i as i32 + 1,
        });
    }
    let pick = |f: fn(&Spec) -> Value| {
        let values: Vec<(&str, Value)> = specs.iter().map(|s| (s.key, f(s))).collect();
        config_msg(&values, specs, false)
    };
    ConfigDescription {
        groups,
        max: pick(|s| s.max),
        min: pick(|s| s.min),
        dflt: pick(|s| s.default),
    }
}

/// The parameter changes a Config carries (group states are ignored: ours are all open).
pub fn changes_from_msg(c: &Config) -> Vec<(String, Value)> {
    let mut out = Vec::new();
    out.extend(c.bools.iter().map(|p| (p.name.clone(), Value::Bool(p.value))));
    out.extend(c.ints.iter().map(|p| (p.name.clone(), Value::Int(p.value))));
    out.extend(c.doubles.iter().map(|p| (p.name.clone(), Value::Double(p.value))));
    out
}

/// The running server; dropping it withdraws the topics and the service.
pub struct Server {
    _service: rosrust::Service,
    _descriptions: rosrust::Publisher<ConfigDescription>,
    _updates: rosrust::Publisher<Config>,
}

/// What the node does with a request: applies the changes (or refuses them
/// all), and returns the outcome and the running values afterwards.
pub type Apply = dyn Fn(&[(String, Value)]) -> (Result<(), ReconfigureError>, Vec<(&'static str, Value)>) + Send + Sync;

fn write_param_server(specs: &[Spec], changes: &[(String, Value)]) {
    for (key, value) in changes {
        let Some(spec) = specs.iter().find(|s| s.key == key) else {
            continue;
        };
        let name = format!("~{}", spec.ros_param());
        let Some(p) = rosrust::param(&name) else {
            continue;
        };
        // Only accepted changes come here: an int sent for a double key became that double.
        let result = match (spec.kind, value) {
            (Kind::Double, Value::Int(v)) => p.set(&f64::from(*v)),
            (_, Value::Double(v)) => p.set(v),
            (_, Value::Int(v)) => p.set(v),
            (_, Value::Bool(v)) => p.set(v),
        };
        if let Err(e) = result {
            log::warn!("dynamic_reconfigure: cannot write {name} to the parameter server: {e}");
        }
    }
}

/// Advertises the description and the running values, and serves requests with `apply`.
pub fn start(specs: Vec<Spec>, initial: &[(&str, Value)], apply: Box<Apply>) -> Result<Server, RosError> {
    let mut descriptions = rosrust::publish::<ConfigDescription>("~parameter_descriptions", 1)
        .map_err(RosError::doing("advertising ~parameter_descriptions"))?;
    descriptions.set_latching(true);
    descriptions
        .send(description_msg(&specs))
        .map_err(RosError::doing("publishing ~parameter_descriptions"))?;
    let mut updates = rosrust::publish::<Config>("~parameter_updates", 1)
        .map_err(RosError::doing("advertising ~parameter_updates"))?;
    updates.set_latching(true);
    updates
        .send(config_msg(initial, &specs, true))
        .map_err(RosError::doing("publishing ~parameter_updates"))?;
    let publisher = updates.clone();
    let service = rosrust::service::<Reconfigure, _>("~set_parameters", move |req| {
        let changes = changes_from_msg(&req.config);
        let (outcome, values) = apply(&changes);
        match &outcome {
            Ok(()) if changes.is_empty() => {}
            Ok(()) => {
                let list: Vec<String> = changes.iter().map(|(k, v)| format!("{k} = {v}")).collect();
                log::info!("dynamic_reconfigure: set {}", list.join(", "));
                write_param_server(&specs, &changes);
            }
            Err(e) => log::error!("dynamic_reconfigure: request refused, running values kept: {e}"),
        }
        let config = config_msg(&values, &specs, true);
        if let Err(e) = publisher.send(config.clone()) {
            log::warn!("publishing ~parameter_updates: {e}");
        }
        Ok(ReconfigureRes { config })
    })
    .map_err(RosError::doing("advertising ~set_parameters"))?;
    Ok(Server {
        _service: service,
        _descriptions: descriptions,
        _updates: updates,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reconfigure::specs;

    #[test]
    fn the_description_has_a_root_group_and_one_group_per_section() {
        let (specs, _) = specs();
        let d = description_msg(&specs);
        assert_eq!((d.groups[0].name.as_str(), d.groups[0].id), ROOT);
        assert!(d.groups[0].parameters.is_empty());
        let barrier = d.groups.iter().find(|g| g.name == "barrier").unwrap();
        assert_eq!(barrier.parent, 0);
        let p = barrier
            .parameters
            .iter()
            .find(|p| p.name == "barrier.d_safe_m")
            .unwrap();
        assert_eq!(p.type_, "double");
        // Every parameter is in exactly one group and in min, max and dflt.
        let n: usize = d.groups.iter().map(|g| g.parameters.len()).sum();
        assert_eq!(n, specs.len());
        for c in [&d.min, &d.max, &d.dflt] {
            assert_eq!(c.doubles.len() + c.ints.len() + c.bools.len(), specs.len());
        }
        let max = d.max.doubles.iter().find(|p| p.name == "barrier.d_safe_m").unwrap();
        assert_eq!(max.value, 10.0);
        let enabled = d.dflt.bools.iter().find(|p| p.name == "obstacles.enabled").unwrap();
        assert!(enabled.value);
    }

    #[test]
    fn a_config_round_trips_and_carries_group_states() {
        let (specs, _) = specs();
        let values = vec![
            ("barrier.d_safe_m", Value::Double(0.3)),
            ("obstacles.enabled", Value::Bool(false)),
            ("x.count", Value::Int(4)),
        ];
        let c = config_msg(&values, &specs, true);
        assert_eq!(c.groups[0].name, "Default");
        assert_eq!(c.groups.len(), 1 + sections(&specs).len());
        let back = changes_from_msg(&c);
        assert_eq!(back.len(), 3);
        for (k, v) in &values {
            assert!(back.contains(&(k.to_string(), *v)), "{k}");
        }
    }
}

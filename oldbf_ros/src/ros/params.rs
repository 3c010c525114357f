//! Reading a node's private parameter namespace as one YAML document.

/// Everything under `~` (null when nothing is set there).
pub fn private_namespace() -> Result<serde_yaml::Value, String> {
    let Some(p) = rosrust::param("~") else {
        return Err("cannot resolve the private parameter namespace `~`".into());
    };
    match p.exists() {
        Ok(false) => Ok(serde_yaml::Value::Null),
        Ok(true) => p
            .get::<serde_yaml::Value>()
            .map_err(|e| format!("reading parameters under {}: {e}", p.name())),
        Err(e) => Err(format!("asking the parameter server for {}: {e}", p.name())),
    }
}

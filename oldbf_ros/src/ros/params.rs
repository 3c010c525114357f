//! Reading a node's private parameter namespace as one YAML document.

use rosrust::error::ResponseError;

/// A parameter that could not be read from the ROS parameter server: its
/// name, and the server's answer where there is one. (A value that was read
/// but is out of range is an `oldbf::config::ParamError`.)
#[derive(Debug, Clone, thiserror::Error)]
pub enum RosParamError {
    #[error("cannot resolve the private parameter namespace `~`")]
    NoPrivateNamespace,
    #[error("asking the parameter server for {name}: {source}")]
    Exists {
        name: String,
        #[source]
        source: ResponseError,
    },
    #[error("reading parameters under {name}: {source}")]
    Namespace {
        name: String,
        #[source]
        source: ResponseError,
    },
    /// A single parameter's name does not resolve.
    #[error("cannot resolve parameter {name}")]
    Unresolved { name: String },
    /// A single parameter could not be asked for or read.
    #[error("parameter {name}: {source}")]
    Read {
        name: String,
        #[source]
        source: ResponseError,
    },
}

/// Everything under `~` (null when nothing is set there).
pub fn private_namespace() -> Result<serde_yaml::Value, RosParamError> {
    let Some(p) = rosrust::param("~") else {
        return Err(RosParamError::NoPrivateNamespace);
    };
    match p.exists() {
        Ok(false) => Ok(serde_yaml::Value::Null),
        Ok(true) => p.get::<serde_yaml::Value>().map_err(|source| RosParamError::Namespace {
            name: p.name().to_string(),
            source,
        }),
        Err(source) => Err(RosParamError::Exists {
            name: p.name().to_string(),
            source,
        }),
    }
}

/// One parameter by name (relative names resolve in the node's namespace);
/// `None` when it is not set.
pub fn read_param<T: for<'de> serde::Deserialize<'de>>(name: &str) -> Result<Option<T>, RosParamError> {
    let p = rosrust::param(name).ok_or_else(|| RosParamError::Unresolved { name: name.to_string() })?;
    let read = |source| RosParamError::Read {
        name: p.name().to_string(),
        source,
    };
    match p.exists() {
        Ok(false) => Ok(None),
        Ok(true) => p.get::<T>().map(Some).map_err(read),
        Err(source) => Err(read(source)),
    }
}

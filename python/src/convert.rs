//! Engine values as Python ones: numpy arrays of vectors and the observables as a dict.

use carom_engine::{Observables, Vector};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// `(N, d)` float64 array of one vector per particle.
pub(crate) fn vectors<'py, V: Vector>(
    py: Python<'py>,
    values: &[V],
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let flat: Vec<f64> = values
        .iter()
        .flat_map(|v| (0..V::DIM).map(move |a| v.get(a)))
        .collect();
    let array = Array2::from_shape_vec((values.len(), V::DIM), flat)
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok(array.into_pyarray(py))
}

/// `(d,)` float64 array of one vector.
pub(crate) fn vector<'py, V: Vector>(py: Python<'py>, v: V) -> Bound<'py, PyArray1<f64>> {
    let values: Vec<f64> = (0..V::DIM).map(|a| v.get(a)).collect();
    PyArray1::from_vec(py, values)
}

pub(crate) fn observables<'py>(py: Python<'py>, o: &Observables) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("step", o.step)?;
    d.set_item("time", o.time)?;
    d.set_item("kinetic_energy", o.kinetic_energy)?;
    d.set_item("potential_energy", o.potential_energy)?;
    d.set_item("temperature", o.temperature)?;
    d.set_item("collisions", o.collisions)?;
    d.set_item("pressure", o.pressure)?;
    d.set_item("max_overlap", o.max_overlap)?;
    Ok(d)
}

//! Log-gradient illumination restoration (paper section 3, eq. 5-8). Placeholder
//! until the filter issue lands.

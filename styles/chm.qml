<!DOCTYPE qgis PUBLIC 'http://mrcc.com/qgis.dtd' 'SYSTEM'>
<qgis minScale="1e+08" version="3.22.16-Białowieża" hasScaleBasedVisibilityFlag="0" styleCategories="AllStyleCategories" maxScale="0">
  <flags>
    <Identifiable>1</Identifiable>
    <Removable>1</Removable>
    <Searchable>1</Searchable>
    <Private>0</Private>
  </flags>
  <temporal fetchMode="0" enabled="0" mode="0">
    <fixedRange>
      <start></start>
      <end></end>
    </fixedRange>
  </temporal>
  <customproperties>
    <Option type="Map">
      <Option value="Value" type="QString" name="identify/format"/>
    </Option>
  </customproperties>
  <pipe-data-defined-properties>
    <Option type="Map">
      <Option value="" type="QString" name="name"/>
      <Option name="properties"/>
      <Option value="collection" type="QString" name="type"/>
    </Option>
  </pipe-data-defined-properties>
  <pipe>
    <provider>
      <resampling zoomedOutResamplingMethod="nearestNeighbour" maxOversampling="2" zoomedInResamplingMethod="nearestNeighbour" enabled="false"/>
    </provider>
    <rasterrenderer opacity="1" classificationMin="0" nodataColor="" alphaBand="-1" classificationMax="40" band="1" type="singlebandpseudocolor">
      <minMaxOrigin>
        <limits>None</limits>
        <extent>WholeRaster</extent>
        <statAccuracy>Estimated</statAccuracy>
        <cumulativeCutLower>0.02</cumulativeCutLower>
        <cumulativeCutUpper>0.98</cumulativeCutUpper>
        <stdDevFactor>2</stdDevFactor>
      </minMaxOrigin>
      <rastershader>
        <colorrampshader maximumValue="40" colorRampType="INTERPOLATED" minimumValue="0" classificationMode="1" labelPrecision="6" clip="0">
          <colorramp type="gradient" name="[source]">
            <Option type="Map">
              <Option value="68,1,84,255" type="QString" name="color1"/>
              <Option value="253,231,37,255" type="QString" name="color2"/>
              <Option value="0" type="QString" name="discrete"/>
              <Option value="gradient" type="QString" name="rampType"/>
              <Option value="0.0196078;70,8,92,255:0.0392157;71,16,99,255:0.0588235;72,23,105,255:0.0784314;72,29,111,255:0.0980392;72,36,117,255:0.117647;71,42,122,255:0.137255;70,48,126,255:0.156863;69,55,129,255:0.176471;67,61,132,255:0.196078;65,66,135,255:0.215686;63,72,137,255:0.235294;61,78,138,255:0.254902;58,83,139,255:0.27451;56,89,140,255:0.294118;53,94,141,255:0.313725;51,99,141,255:0.333333;49,104,142,255:0.352941;46,109,142,255:0.372549;44,113,142,255:0.392157;42,118,142,255:0.411765;41,123,142,255:0.431373;39,128,142,255:0.45098;37,132,142,255:0.470588;35,137,142,255:0.490196;33,142,141,255:0.509804;32,146,140,255:0.529412;31,151,139,255:0.54902;30,156,137,255:0.568627;31,161,136,255:0.588235;33,165,133,255:0.607843;36,170,131,255:0.627451;40,174,128,255:0.647059;46,179,124,255:0.666667;53,183,121,255:0.686275;61,188,116,255:0.705882;70,192,111,255:0.72549;80,196,106,255:0.745098;90,200,100,255:0.764706;101,203,94,255:0.784314;112,207,87,255:0.803922;124,210,80,255:0.823529;137,213,72,255:0.843137;149,216,64,255:0.862745;162,218,55,255:0.882353;176,221,47,255:0.901961;189,223,38,255:0.921569;202,225,31,255:0.941176;216,226,25,255:0.960784;229,228,25,255:0.980392;241,229,29,255" type="QString" name="stops"/>
            </Option>
            <prop v="68,1,84,255" k="color1"/>
            <prop v="253,231,37,255" k="color2"/>
            <prop v="0" k="discrete"/>
            <prop v="gradient" k="rampType"/>
            <prop v="0.0196078;70,8,92,255:0.0392157;71,16,99,255:0.0588235;72,23,105,255:0.0784314;72,29,111,255:0.0980392;72,36,117,255:0.117647;71,42,122,255:0.137255;70,48,126,255:0.156863;69,55,129,255:0.176471;67,61,132,255:0.196078;65,66,135,255:0.215686;63,72,137,255:0.235294;61,78,138,255:0.254902;58,83,139,255:0.27451;56,89,140,255:0.294118;53,94,141,255:0.313725;51,99,141,255:0.333333;49,104,142,255:0.352941;46,109,142,255:0.372549;44,113,142,255:0.392157;42,118,142,255:0.411765;41,123,142,255:0.431373;39,128,142,255:0.45098;37,132,142,255:0.470588;35,137,142,255:0.490196;33,142,141,255:0.509804;32,146,140,255:0.529412;31,151,139,255:0.54902;30,156,137,255:0.568627;31,161,136,255:0.588235;33,165,133,255:0.607843;36,170,131,255:0.627451;40,174,128,255:0.647059;46,179,124,255:0.666667;53,183,121,255:0.686275;61,188,116,255:0.705882;70,192,111,255:0.72549;80,196,106,255:0.745098;90,200,100,255:0.764706;101,203,94,255:0.784314;112,207,87,255:0.803922;124,210,80,255:0.823529;137,213,72,255:0.843137;149,216,64,255:0.862745;162,218,55,255:0.882353;176,221,47,255:0.901961;189,223,38,255:0.921569;202,225,31,255:0.941176;216,226,25,255:0.960784;229,228,25,255:0.980392;241,229,29,255" k="stops"/>
          </colorramp>
          <item color="#440154" value="0" alpha="255" label="0"/>
          <item color="#46085c" value="0.784312" alpha="255" label="0.784"/>
          <item color="#471063" value="1.568628" alpha="255" label="1.57"/>
          <item color="#481769" value="2.35294" alpha="255" label="2.35"/>
          <item color="#481d6f" value="3.137256" alpha="255" label="3.14"/>
          <item color="#482475" value="3.921568" alpha="255" label="3.92"/>
          <item color="#472a7a" value="4.705880000000001" alpha="255" label="4.71"/>
          <item color="#46307e" value="5.4902" alpha="255" label="5.49"/>
          <item color="#453781" value="6.27452" alpha="255" label="6.27"/>
          <item color="#433d84" value="7.05884" alpha="255" label="7.06"/>
          <item color="#414287" value="7.84312" alpha="255" label="7.84"/>
          <item color="#3f4889" value="8.62744" alpha="255" label="8.63"/>
          <item color="#3d4e8a" value="9.411760000000001" alpha="255" label="9.41"/>
          <item color="#3a538b" value="10.19608" alpha="255" label="10.2"/>
          <item color="#38598c" value="10.9804" alpha="255" label="11"/>
          <item color="#355e8d" value="11.76472" alpha="255" label="11.8"/>
          <item color="#33638d" value="12.549" alpha="255" label="12.5"/>
          <item color="#31688e" value="13.33332" alpha="255" label="13.3"/>
          <item color="#2e6d8e" value="14.11764" alpha="255" label="14.1"/>
          <item color="#2c718e" value="14.90196" alpha="255" label="14.9"/>
          <item color="#2a768e" value="15.68628" alpha="255" label="15.7"/>
          <item color="#297b8e" value="16.4706" alpha="255" label="16.5"/>
          <item color="#27808e" value="17.25492" alpha="255" label="17.3"/>
          <item color="#25848e" value="18.0392" alpha="255" label="18"/>
          <item color="#23898e" value="18.823520000000002" alpha="255" label="18.8"/>
          <item color="#218e8d" value="19.60784" alpha="255" label="19.6"/>
          <item color="#20928c" value="20.39216" alpha="255" label="20.4"/>
          <item color="#1f978b" value="21.176479999999998" alpha="255" label="21.2"/>
          <item color="#1e9c89" value="21.9608" alpha="255" label="22"/>
          <item color="#1fa188" value="22.74508" alpha="255" label="22.7"/>
          <item color="#21a585" value="23.5294" alpha="255" label="23.5"/>
          <item color="#24aa83" value="24.31372" alpha="255" label="24.3"/>
          <item color="#28ae80" value="25.098039999999997" alpha="255" label="25.1"/>
          <item color="#2eb37c" value="25.882360000000002" alpha="255" label="25.9"/>
          <item color="#35b779" value="26.66668" alpha="255" label="26.7"/>
          <item color="#3dbc74" value="27.451" alpha="255" label="27.5"/>
          <item color="#46c06f" value="28.23528" alpha="255" label="28.2"/>
          <item color="#50c46a" value="29.019599999999997" alpha="255" label="29"/>
          <item color="#5ac864" value="29.80392" alpha="255" label="29.8"/>
          <item color="#65cb5e" value="30.58824" alpha="255" label="30.6"/>
          <item color="#70cf57" value="31.37256" alpha="255" label="31.4"/>
          <item color="#7cd250" value="32.15688" alpha="255" label="32.2"/>
          <item color="#89d548" value="32.941159999999996" alpha="255" label="32.9"/>
          <item color="#95d840" value="33.725480000000005" alpha="255" label="33.7"/>
          <item color="#a2da37" value="34.5098" alpha="255" label="34.5"/>
          <item color="#b0dd2f" value="35.29412" alpha="255" label="35.3"/>
          <item color="#bddf26" value="36.07844" alpha="255" label="36.1"/>
          <item color="#cae11f" value="36.86276" alpha="255" label="36.9"/>
          <item color="#d8e219" value="37.647040000000004" alpha="255" label="37.6"/>
          <item color="#e5e419" value="38.43136" alpha="255" label="38.4"/>
          <item color="#f1e51d" value="39.21568" alpha="255" label="39.2"/>
          <item color="#fde725" value="40" alpha="255" label="40"/>
          <rampLegendSettings direction="0" suffix="" maximumLabel="" useContinuousLegend="1" orientation="2" minimumLabel="" prefix="">
            <numericFormat id="basic">
              <Option type="Map">
                <Option value="" type="QChar" name="decimal_separator"/>
                <Option value="6" type="int" name="decimals"/>
                <Option value="0" type="int" name="rounding_type"/>
                <Option value="false" type="bool" name="show_plus"/>
                <Option value="true" type="bool" name="show_thousand_separator"/>
                <Option value="false" type="bool" name="show_trailing_zeros"/>
                <Option value="" type="QChar" name="thousand_separator"/>
              </Option>
            </numericFormat>
          </rampLegendSettings>
        </colorrampshader>
      </rastershader>
    </rasterrenderer>
    <brightnesscontrast gamma="1" contrast="0" brightness="0"/>
    <huesaturation invertColors="0" colorizeBlue="128" colorizeGreen="128" colorizeOn="0" saturation="0" colorizeStrength="100" colorizeRed="255" grayscaleMode="0"/>
    <rasterresampler maxOversampling="2"/>
    <resamplingStage>resamplingFilter</resamplingStage>
  </pipe>
  <blendMode>0</blendMode>
</qgis>

<?xml version="1.0" encoding="utf-8"?>
<!DOCTYPE TS>
<TS version="2.1" language="pt_BR" sourcelanguage="en">
  <context>
    <name>LidarTrees</name>
    <message>
      <source>LiDAR Trees (lidartrees_gis)</source>
      <translation>LiDAR Trees (lidartrees_gis)</translation>
    </message>
    <message>
      <source>Point clouds and rasters</source>
      <translation>Nuvens de pontos e rasters</translation>
    </message>
    <message>
      <source>Tree tables</source>
      <translation>Tabelas de árvores</translation>
    </message>
    <message>
      <source>All files</source>
      <translation>Todos os arquivos</translation>
    </message>
    <message>
      <source>…or a point-cloud layer loaded in QGIS</source>
      <translation>…ou uma camada de nuvem de pontos carregada no QGIS</translation>
    </message>
    <message>
      <source>Information (JSON)</source>
      <translation>Informações (JSON)</translation>
    </message>
    <message>
      <source>Number of points</source>
      <translation>Número de pontos</translation>
    </message>
    <message>
      <source>Number of trees</source>
      <translation>Número de árvores</translation>
    </message>
    <message>
      <source>Cell size (m), or auto</source>
      <translation>Tamanho da célula (m), ou auto</translation>
    </message>
    <message>
      <source>Reference:</source>
      <translation>Referência:</translation>
    </message>
    <message>
      <source>Command line:</source>
      <translation>Linha de comando:</translation>
    </message>
    <message>
      <source>GeoPackage (*.gpkg)</source>
      <translation>GeoPackage (*.gpkg)</translation>
    </message>
    <message>
      <source>JSON report (*.json)</source>
      <translation>Relatório JSON (*.json)</translation>
    </message>
    <message>
      <source>Matched pairs CSV (*.csv)</source>
      <translation>CSV dos pares associados (*.csv)</translation>
    </message>
    <message>
      <source>cancelled: no output written</source>
      <translation>cancelado: nenhuma saída gravada</translation>
    </message>
    <message>
      <source>Give the input: a point file (Input), or a point-cloud layer loaded in QGIS</source>
      <translation>Informe a entrada: um arquivo de pontos (Entrada) ou uma camada de nuvem de pontos carregada no QGIS</translation>
    </message>
    <message>
      <source>The point-cloud layer '{name}' is not a local file ({src}); export it to LAS/LAZ first</source>
      <translation>A camada de nuvem de pontos '{name}' não é um arquivo local ({src}); exporte-a antes para LAS/LAZ</translation>
    </message>
    <message>
      <source>Unknown parameter(s) {unknown} for {alg}; its parameters are {known}</source>
      <translation>Parâmetro(s) desconhecido(s) {unknown} para {alg}; os parâmetros dele são {known}</translation>
    </message>
    <message>
      <source>{pid}: cannot save the layer '{name}' for the command ({error})</source>
      <translation>{pid}: não foi possível salvar a camada '{name}' para o comando ({error})</translation>
    </message>
    <message>
      <source>LiDAR Trees: the 'lidartrees' command was not found. Install the lidartrees_gis package from its source folder (the one holding pyproject.toml) or its wheel (lidartrees_gis-*.whl) in its own environment (python3 -m venv ~/.venvs/lidartrees &amp;&amp; ~/.venvs/lidartrees/bin/pip install /path/to/lidartrees_gis; it is not published on PyPI) and, if it is not on the PATH, set the environment variable LIDARTREES_EXE or the QGIS setting '{setting}' to its path.</source>
      <translation>LiDAR Trees: o comando 'lidartrees' não foi encontrado. Instale o pacote lidartrees_gis a partir da sua pasta de código (a que contém pyproject.toml) ou do seu wheel (lidartrees_gis-*.whl) em um ambiente próprio (python3 -m venv ~/.venvs/lidartrees &amp;&amp; ~/.venvs/lidartrees/bin/pip install /caminho/para/lidartrees_gis; ele não está publicado no PyPI) e, se ele não estiver no PATH, defina a variável de ambiente LIDARTREES_EXE ou a configuração do QGIS '{setting}' com o caminho dele.</translation>
    </message>
    <message>
      <source>LiDAR Trees: '{exe} --version' failed: {error}</source>
      <translation>LiDAR Trees: '{exe} --version' falhou: {error}</translation>
    </message>
    <message>
      <source>LiDAR Trees: cannot run {exe}: {error}</source>
      <translation>LiDAR Trees: não foi possível executar {exe}: {error}</translation>
    </message>
    <message>
      <source>Points</source>
      <translation>Pontos</translation>
    </message>
    <message>
      <source>Points, bounds, density, CRS, classes and returns of a point file</source>
      <translation>Pontos, limites, densidade, SRC, classes e retornos de um arquivo de pontos</translation>
    </message>
    <message>
      <source>Input</source>
      <translation>Entrada</translation>
    </message>
    <message>
      <source>Point file: LAS/LAZ or XYZ text (tab/space/comma/semicolon, decimal comma or point, optional header, may be gzip-compressed)</source>
      <translation>Arquivo de pontos: LAS/LAZ ou texto XYZ (tabulação/espaço/vírgula/ponto e vírgula, vírgula ou ponto decimal, cabeçalho opcional, pode estar comprimido em gzip)</translation>
    </message>
    <message>
      <source>CRS of the input (assign)</source>
      <translation>SRC da entrada (atribuir)</translation>
    </message>
    <message>
      <source>Assign this CRS to the input (EPSG code, WKT, PROJ, or SAD69/UTM24S, 'SAD69 24K', SIRGAS2000/UTM24S); required for XYZ text without a .prj</source>
      <translation>Atribui este SRC à entrada (código EPSG, WKT, PROJ, ou SAD69/UTM24S, 'SAD69 24K', SIRGAS2000/UTM24S); obrigatório para texto XYZ sem um .prj</translation>
    </message>
    <message>
      <source>Reproject to CRS</source>
      <translation>Reprojetar para o SRC</translation>
    </message>
    <message>
      <source>Reproject the points to this CRS (the operation used and its accuracy are reported)</source>
      <translation>Reprojeta os pontos para este SRC (a operação usada e a sua exatidão são informadas)</translation>
    </message>
    <message>
      <source>Text delimiter</source>
      <translation>Delimitador do texto</translation>
    </message>
    <message>
      <source>XYZ column delimiter: tab, space, comma, semicolon (detected when not given)</source>
      <translation>Delimitador das colunas XYZ: tabulação, espaço, vírgula, ponto e vírgula (detectado quando não informado)</translation>
    </message>
    <message>
      <source>XYZ numbers use a decimal comma</source>
      <translation>Os números XYZ usam vírgula decimal</translation>
    </message>
    <message>
      <source>XYZ numbers use a decimal comma (detected when not given)</source>
      <translation>Os números XYZ usam vírgula decimal (detectado quando não informado)</translation>
    </message>
    <message>
      <source>Text columns (x,y,z,...)</source>
      <translation>Colunas do texto (x,y,z,...)</translation>
    </message>
    <message>
      <source>XYZ column names in order, e.g. x,y,z,intensity,classification (- skips a column); default from the header or x,y,z</source>
      <translation>Nomes das colunas XYZ em ordem, p. ex. x,y,z,intensity,classification (- pula uma coluna); padrão: do cabeçalho, ou x,y,z</translation>
    </message>
    <message>
      <source>Skip malformed text lines</source>
      <translation>Pular linhas de texto malformadas</translation>
    </message>
    <message>
      <source>Skip malformed XYZ lines and report how many, instead of failing</source>
      <translation>Pula as linhas XYZ malformadas e informa quantas, em vez de falhar</translation>
    </message>
    <message>
      <source>Rasters</source>
      <translation>Rasters</translation>
    </message>
    <message>
      <source>Grid points into a GeoTIFF with one statistic per cell</source>
      <translation>Grade dos pontos em um GeoTIFF com uma estatística por célula</translation>
    </message>
    <message>
      <source>Output</source>
      <translation>Saída</translation>
    </message>
    <message>
      <source>Output GeoTIFF</source>
      <translation>GeoTIFF de saída</translation>
    </message>
    <message>
      <source>Cell size</source>
      <translation>Tamanho da célula</translation>
    </message>
    <message>
      <source>Cell size in metres, or auto = sqrt(1/n) from the point density n (Leite et al.)</source>
      <translation>Tamanho da célula em metros, ou auto = sqrt(1/n) a partir da densidade de pontos n (Leite et al.)</translation>
    </message>
    <message>
      <source>Per-cell statistic of z</source>
      <translation>Estatística de z por célula</translation>
    </message>
    <message>
      <source>Gap filling</source>
      <translation>Preenchimento de vazios</translation>
    </message>
    <message>
      <source>Gap filling: mean8 = empty cells take the mean of their filled 8-neighbours, repeated until none is left (Castro 2006); chm and trees fill only the data's footprint, the cells within 2 m (or 3 point spacings) of a return, and leave nodata beyond it; none = leave nodata</source>
      <translation>Preenchimento de vazios: mean8 = as células vazias recebem a média das suas 8 vizinhas preenchidas, repetido até não restar nenhuma (Castro 2006); chm e trees preenchem só a área coberta pelos dados, as células a até 2 m (ou 3 espaçamentos entre pontos) de um retorno, e deixam nodata além dela; none = deixar nodata</translation>
    </message>
    <message>
      <source>Leave out LAS classes</source>
      <translation>Excluir classes LAS</translation>
    </message>
    <message>
      <source>Leave out points of these LAS classes (comma list; default 7,18 = low and high noise; none keeps all)</source>
      <translation>Exclui os pontos destas classes LAS (lista separada por vírgulas; padrão 7,18 = ruído baixo e alto; none mantém todas)</translation>
    </message>
    <message>
      <source>Use only LAS classes</source>
      <translation>Usar só as classes LAS</translation>
    </message>
    <message>
      <source>Use only points of these LAS classes (comma list, e.g. 1,2,3,4,5)</source>
      <translation>Usa só os pontos destas classes LAS (lista separada por vírgulas, p. ex. 1,2,3,4,5)</translation>
    </message>
    <message>
      <source>Tile size</source>
      <translation>Tamanho do bloco</translation>
    </message>
    <message>
      <source>Process in square tiles of this side (m), each with a buffer (a single file is processed as a catalog of one); auto (default) = one tile for an area of at most 1 M points and 1 km across, else a side of about 500,000 points (250 m in dense data, up to 1000 m in sparse data); none = one tile</source>
      <translation>Processa em blocos quadrados deste lado (m), cada um com uma borda (um arquivo único é processado como um catálogo de um arquivo); auto (padrão) = um bloco para uma área de até 1 M de pontos e 1 km de extensão, senão um lado de cerca de 500.000 pontos (250 m em dados densos, até 1000 m em dados esparsos); none = um bloco</translation>
    </message>
    <message>
      <source>Tile buffer</source>
      <translation>Borda do bloco</translation>
    </message>
    <message>
      <source>Buffer around each tile (default: trees 8 crown scales, at least 20 m; chm 20 m; grid none, 20 m with -fill mean8)</source>
      <translation>Borda em torno de cada bloco (padrão: trees 8 escalas de copa, no mínimo 20 m; chm 20 m; grid nenhuma, 20 m com -fill mean8)</translation>
    </message>
    <message>
      <source>Workers</source>
      <translation>Processos</translation>
    </message>
    <message>
      <source>Worker processes of the local Dask cluster (default: all cores, or this process below 1 M points, where starting a cluster costs more than it saves; 1 = in this process)</source>
      <translation>Processos de trabalho do cluster Dask local (padrão: todos os núcleos, ou este processo abaixo de 1 M de pontos, onde iniciar um cluster custa mais do que economiza; 1 = neste processo)</translation>
    </message>
    <message>
      <source>Dask scheduler address</source>
      <translation>Endereço do agendador Dask</translation>
    </message>
    <message>
      <source>Address of an existing Dask scheduler to run the tiles on, e.g. tcp://10.0.0.5:8786 (the workers must read the inputs at the same absolute paths)</source>
      <translation>Endereço de um agendador Dask existente onde rodar os blocos, p. ex. tcp://10.0.0.5:8786 (os processos de trabalho precisam ler as entradas nos mesmos caminhos absolutos)</translation>
    </message>
    <message>
      <source>When a tile fails</source>
      <translation>Quando um bloco falha</translation>
    </message>
    <message>
      <source>A tile that fails (twice on Dask): stop = stop the run, no output written; skip = write the other tiles' results, then fail naming the tiles left out</source>
      <translation>Um bloco que falha (duas vezes no Dask): stop = interrompe a execução, nenhuma saída gravada; skip = grava os resultados dos outros blocos e então falha indicando os blocos que ficaram de fora</translation>
    </message>
    <message>
      <source>Resume a killed run</source>
      <translation>Retomar uma execução interrompida</translation>
    </message>
    <message>
      <source>Continue a killed or failed run of several tiles from the tiles it kept beside its output (same command and inputs)</source>
      <translation>Continua uma execução de vários blocos que foi interrompida ou falhou, a partir dos blocos que ela guardou ao lado da sua saída (mesmo comando e mesmas entradas)</translation>
    </message>
    <message>
      <source>Allow outputs without a CRS</source>
      <translation>Permitir saídas sem SRC</translation>
    </message>
    <message>
      <source>Write outputs without a CRS when the input has none (default: refused; give -a_srs)</source>
      <translation>Grava as saídas sem SRC quando a entrada não tem nenhum (padrão: recusado; informe -a_srs)</translation>
    </message>
    <message>
      <source>GeoTIFF creation options</source>
      <translation>Opções de criação do GeoTIFF</translation>
    </message>
    <message>
      <source>GDAL creation option KEY=VALUE for GeoTIFF outputs (repeatable)</source>
      <translation>Opção de criação do GDAL CHAVE=VALOR para as saídas GeoTIFF (repetível)</translation>
    </message>
    <message>
      <source>Replace existing outputs</source>
      <translation>Substituir as saídas existentes</translation>
    </message>
    <message>
      <source>Canopy height model CHM = DSM (highest point per cell) - DTM</source>
      <translation>Modelo de altura do dossel CHM = MDS (ponto mais alto por célula) - MDT</translation>
    </message>
    <message>
      <source>Output CHM GeoTIFF</source>
      <translation>GeoTIFF do CHM de saída</translation>
    </message>
    <message>
      <source>Cell size of the CHM built from points, m, or auto = max(sqrt(1/n), 0.25) from the point density n, rounded to 0.05 m</source>
      <translation>Tamanho da célula do CHM gerado a partir dos pontos, m, ou auto = max(sqrt(1/n), 0,25) a partir da densidade de pontos n, arredondado a 0,05 m</translation>
    </message>
    <message>
      <source>Terrain model (DTM)</source>
      <translation>Modelo digital do terreno (MDT)</translation>
    </message>
    <message>
      <source>DTM: auto = class-2 ground points if the file has them, else lowest:5; ground = class-2 points interpolated (TIN); lowest:R = lowest point per R m cell, interpolated; kp or kp:G:W = Kraus &amp; Pfeifer ground filter (Leite et al.); min = lowest point per cell (Castro 2006; only where every cell holds ground returns); none = heights already normalised; or a DTM GeoTIFF path</source>
      <translation>MDT: auto = pontos de solo de classe 2 se o arquivo os tiver, senão lowest:5; ground = pontos de classe 2 interpolados (TIN); lowest:R = ponto mais baixo por célula de R m, interpolado; kp ou kp:G:W = filtro de solo de Kraus &amp; Pfeifer (Leite et al.); min = ponto mais baixo por célula (Castro 2006; só onde toda célula contém retornos do solo); none = alturas já normalizadas; ou o caminho de um GeoTIFF de MDT</translation>
    </message>
    <message>
      <source>Canopy height model</source>
      <translation>Modelo de altura do dossel</translation>
    </message>
    <message>
      <source>CHM from points: pitfree = pit-free CHM of the first returns (Khosravipour et al. 2014); max = highest point per cell, gaps filled (Castro 2006); tin = one TIN of the first returns</source>
      <translation>CHM a partir dos pontos: pitfree = CHM sem buracos dos primeiros retornos (Khosravipour et al. 2014); max = ponto mais alto por célula, vazios preenchidos (Castro 2006); tin = um TIN dos primeiros retornos</translation>
    </message>
    <message>
      <source>Keep points far above the canopy</source>
      <translation>Manter pontos muito acima do dossel</translation>
    </message>
    <message>
      <source>Keep isolated returns far above the canopy (birds, clouds, unclassified noise), which are removed by default</source>
      <translation>Mantém os retornos isolados muito acima do dossel (aves, nuvens, ruído não classificado), que por padrão são removidos</translation>
    </message>
    <message>
      <source>Also write the DSM here</source>
      <translation>Gravar também o MDS aqui</translation>
    </message>
    <message>
      <source>Terrain model output</source>
      <translation>MDT de saída</translation>
    </message>
    <message>
      <source>Also write the DTM here</source>
      <translation>Gravar também o MDT aqui</translation>
    </message>
    <message>
      <source>Trees</source>
      <translation>Árvores</translation>
    </message>
    <message>
      <source>Tree tops, crowns and a stand summary (GeoPackage) from points or a CHM</source>
      <translation>Árvores: topos, copas e resumo do talhão (GeoPackage) a partir de pontos ou de um CHM</translation>
    </message>
    <message>
      <source>Point file (LAS/LAZ, XYZ) or a CHM GeoTIFF</source>
      <translation>Arquivo de pontos (LAS/LAZ, XYZ) ou um GeoTIFF de CHM</translation>
    </message>
    <message>
      <source>Output GeoPackage (.gpkg)</source>
      <translation>GeoPackage de saída (.gpkg)</translation>
    </message>
    <message>
      <source>Crown segmentation</source>
      <translation>Segmentação das copas</translation>
    </message>
    <message>
      <source>Crowns: rg = region growing (Castro 2006 / Hyyppä 2001); treex = TreeX priority growing (Pantaleão et al.); watershed = Vincent-Soille on the inverted CHM (Castro 2006); mcws = marker-controlled watershed from the tops</source>
      <translation>Copas: rg = crescimento de regiões (Castro 2006 / Hyyppä 2001); treex = crescimento por prioridade do TreeX (Pantaleão et al.); watershed = Vincent-Soille sobre o CHM invertido (Castro 2006); mcws = watershed controlado por marcadores a partir dos topos</translation>
    </message>
    <message>
      <source>Smoothing</source>
      <translation>Suavização</translation>
    </message>
    <message>
      <source>CHM filter: auto = a Gaussian sized from the crown scale (measured on the CHM, or from -spacing); none; gauss3 (Castro's fine mask); gauss5 (coarse mask); gauss:SIGMA (m); or OP:ELEMENT[:SIZE], OP in erode, dilate, open, close, abefec, fecabe, fecabefec, abefecabe; ELEMENT cross, square, rhombus. Default: auto, but none with -method treex or watershed (their papers work on the raw height model)</source>
      <translation>Filtro do MDC: auto = um gaussiano dimensionado pela escala das copas (medida no MDC, ou a partir de -spacing); none; gauss3 (máscara fina de Castro); gauss5 (máscara grossa); gauss:SIGMA (m); ou OP:ELEMENTO[:TAMANHO], OP entre erode, dilate, open, close, abefec, fecabe, fecabefec, abefecabe; ELEMENTO cross, square, rhombus. Padrão: auto, mas none com -method treex ou watershed (seus artigos trabalham sobre o modelo de altura bruto)</translation>
    </message>
    <message>
      <source>Minimum tree height</source>
      <translation>Altura mínima da árvore</translation>
    </message>
    <message>
      <source>Planting spacing (rows x trees)</source>
      <translation>Espaçamento de plantio (linhas x plantas)</translation>
    </message>
    <message>
      <source>Plantation mode: planting spacing ROWSxTREES in m, e.g. 3x2, or auto (found under the tops, per stand with -stands); each empty planting position classified missing, suppressed or uncertain (gaps layer), and stocking, added to the output. Default: auto with -stands (a stand that shows no lattice keeps the defaults' trees); without, auto over the planted blocks between roads where the canopy shows planting rows</source>
      <translation>Modo plantio: espaçamento de plantio LINHASxPLANTAS em m, p. ex. 3x2, ou auto (encontrado sob os topos, por talhão com -stands); cada cova vazia classificada como falha, dominada ou incerta (camada gaps), e o estoque, acrescentados à saída. Padrão: auto com -stands (um talhão que não mostra grade de plantio fica com as árvores do padrão); sem -stands, auto nos blocos plantados entre os carreadores onde o dossel mostra linhas de plantio</translation>
    </message>
    <message>
      <source>Tree-top rule</source>
      <translation>Regra dos topos</translation>
    </message>
    <message>
      <source>Tree tops: aw = adaptive window (crown scale x height); lm = 8-neighbour maxima, one per plateau (Castro 2006); strict = strictly higher than all 8 neighbours, grid-border cells excluded (Castro's literal rule); treex = TreeX window; vwf = window 0.1 h + 0.5 m; auto = treex for -method treex, aw with -smooth auto, else lm</source>
      <translation>Topos das árvores: aw = janela adaptativa (escala de copa x altura); lm = máximos em 8 vizinhos, um por platô (Castro 2006); strict = estritamente mais alto que os 8 vizinhos, células da borda da grade excluídas (a regra literal de Castro); treex = janela do TreeX; vwf = janela 0,1 h + 0,5 m; auto = treex com -method treex, aw com -smooth auto, senão lm</translation>
    </message>
    <message>
      <source>Crown scale</source>
      <translation>Escala de copa</translation>
    </message>
    <message>
      <source>Crown scale for -smooth auto and -tops aw (default: measured on the CHM)</source>
      <translation>Escala de copa para -smooth auto e -tops aw (padrão: medida no CHM)</translation>
    </message>
    <message>
      <source>Window factor</source>
      <translation>Fator da janela</translation>
    </message>
    <message>
      <source>Adaptive window radius for a tree of the dominant height, in crown scales</source>
      <translation>Raio da janela adaptativa para uma árvore da altura dominante, em escalas de copa</translation>
    </message>
    <message>
      <source>Smallest distance between tops</source>
      <translation>Menor distância entre topos</translation>
    </message>
    <message>
      <source>Adaptive window: smallest distance between two tops (default 2.6 CHM cells, 1.3 m at 4 pts/m², at most 1.8 crown scales; with -spacing at least 0.6 x the smaller spacing; 0 = no limit)</source>
      <translation>Janela adaptativa: menor distância entre dois topos (padrão 2,6 células do CHM, 1,3 m a 4 pts/m², no máximo 1,8 escala de copa; com -spacing pelo menos 0,6 x o menor espaçamento; 0 = sem limite)</translation>
    </message>
    <message>
      <source>Planting lattice under the tops (without spacing)</source>
      <translation>Grade de plantio sob os topos (sem espaçamento)</translation>
    </message>
    <message>
      <source>Without -spacing: auto = with -stands, -spacing auto; without, when the tops lie on a planting lattice (at least 100 trees, lattice fit &gt;= 0.25), look again at its empty positions for trees the tops finder missed (each tile with its buffer); none = off. Default: auto with the default method (rg, -smooth auto, -tops auto), none with a seed method or configuration, which then runs as its paper defines it</source>
      <translation>Sem -spacing: auto = com -stands, -spacing auto; sem, quando os topos estão sobre uma grade de plantio (pelo menos 100 árvores, ajuste da grade &gt;= 0,25), procura de novo nas covas vazias as árvores que o localizador de topos perdeu (cada bloco com a sua borda); none = desligado. Padrão: auto com o método padrão (rg, -smooth auto, -tops auto), none com um método ou configuração dos artigos de origem, que então roda como o seu artigo o define</translation>
    </message>
    <message>
      <source>Region-growing step</source>
      <translation>Passo do crescimento de regiões</translation>
    </message>
    <message>
      <source>Region-growing threshold step (ajuste, Castro 2006, Annex 2)</source>
      <translation>Passo do limiar do crescimento de regiões (ajuste, Castro 2006, Anexo 2)</translation>
    </message>
    <message>
      <source>TreeX window: mean crown area</source>
      <translation>Janela do TreeX: área média de copa</translation>
    </message>
    <message>
      <source>TreeX window step: crown-area standard deviation</source>
      <translation>Passo da janela do TreeX: desvio padrão da área de copa</translation>
    </message>
    <message>
      <source>TreeX maximum crown area</source>
      <translation>Área máxima de copa do TreeX</translation>
    </message>
    <message>
      <source>TreeX minimum crown height</source>
      <translation>Altura mínima de copa do TreeX</translation>
    </message>
    <message>
      <source>TreeX growth neighbourhood</source>
      <translation>Vizinhança de crescimento do TreeX</translation>
    </message>
    <message>
      <source>TreeX: also highest of the centred window</source>
      <translation>TreeX: também o mais alto da janela centrada</translation>
    </message>
    <message>
      <source>TreeX: also require each top to be the highest of the window centred on it (drops one of two close trees; not in the seed)</source>
      <translation>TreeX: exige também que cada topo seja o mais alto da janela centrada nele (elimina uma de duas árvores próximas; não está no artigo)</translation>
    </message>
    <message>
      <source>TreeX: also a local maximum of 8 neighbours</source>
      <translation>TreeX: também um máximo local de 8 vizinhos</translation>
    </message>
    <message>
      <source>TreeX: also require each top to be a local maximum of its 8 neighbours (drops crown-flank tops, and trees that lose every window to a taller neighbour; not in the seed)</source>
      <translation>TreeX: exige também que cada topo seja um máximo local dos seus 8 vizinhos (elimina topos na encosta da copa e árvores que perdem toda janela para uma vizinha mais alta; não está no artigo)</translation>
    </message>
    <message>
      <source>DTM for points input (see chm); default auto = class-2 ground points if any, else lowest:5</source>
      <translation>MDT para entrada de pontos (ver chm); padrão auto = pontos de solo de classe 2 se houver, senão lowest:5</translation>
    </message>
    <message>
      <source>Prefix for the layer names</source>
      <translation>Prefixo dos nomes das camadas</translation>
    </message>
    <message>
      <source>Prefix for the layer names (tree_tops, crowns, summary)</source>
      <translation>Prefixo dos nomes das camadas (tree_tops, crowns, summary)</translation>
    </message>
    <message>
      <source>Layer options</source>
      <translation>Opções de camada</translation>
    </message>
    <message>
      <source>GeoPackage layer creation option KEY=VALUE; and for the -csv and -stand_csv tables CSV table option KEY=VALUE: SEPARATOR=COMMA|SEMICOLON|TAB|SPACE, DECIMAL=POINT|COMMA, WRITE_BOM=YES|NO (default: the locale's; pt_BR: semicolon, decimal comma, BOM); a table named .xlsx is a workbook</source>
      <translation>Opção de criação de camada do GeoPackage CHAVE=VALOR; e, para as tabelas -csv e -stand_csv, opção de tabela CSV CHAVE=VALOR: SEPARATOR=COMMA|SEMICOLON|TAB|SPACE, DECIMAL=POINT|COMMA, WRITE_BOM=YES|NO (padrão: o do idioma do sistema; pt_BR: ponto e vírgula, vírgula decimal, BOM); uma tabela com nome .xlsx é uma planilha</translation>
    </message>
    <message>
      <source>Quick-look PNG</source>
      <translation>PNG de visualização rápida</translation>
    </message>
    <message>
      <source>Also write a quick-look PNG (the CHM in height classes with a legend, crown outlines, tops, coordinates, scale bar, the summary as title)</source>
      <translation>Gravar também um PNG de visualização rápida (o CHM em classes de altura com legenda, contornos das copas, topos, coordenadas, barra de escala, o resumo como título)</translation>
    </message>
    <message>
      <source>Quick-look title</source>
      <translation>Título da visualização rápida</translation>
    </message>
    <message>
      <source>The quick look's title (default: the input's name and the summary)</source>
      <translation>O título da visualização rápida (padrão: o nome da entrada e o resumo)</translation>
    </message>
    <message>
      <source>Trees CSV</source>
      <translation>Tabela de árvores (CSV)</translation>
    </message>
    <message>
      <source>Also write the trees as a table (.csv, or .xlsx): tree_id, stand_id, row_number, plant_number, x, y, height, crown_diameter, crown_area, suppressed, chm_row, chm_col</source>
      <translation>Gravar também as árvores como tabela (.csv ou .xlsx): tree_id, stand_id, row_number (linha), plant_number (planta), x, y, height, crown_diameter, crown_area, suppressed, chm_row, chm_col</translation>
    </message>
    <message>
      <source>Also write the CHM GeoTIFF</source>
      <translation>Gravar também o GeoTIFF do CHM</translation>
    </message>
    <message>
      <source>Stands (talhões) polygon layer</source>
      <translation>Camada de polígonos dos talhões</translation>
    </message>
    <message>
      <source>Stand (talhão) polygons, PATH or PATH:LAYER of any OGR polygon source (GeoPackage, shapefile): every tree, crown and gap gets its stand_id and a stands layer the per-stand inventory (trees/ha, mean and dominant height, crown diameter, canopy cover, height classes; with -spacing each stand's own lattice and stocking)</source>
      <translation>Polígonos dos talhões, CAMINHO ou CAMINHO:CAMADA de qualquer fonte de polígonos OGR (GeoPackage, shapefile): cada árvore, copa e falha recebe o seu stand_id, e uma camada stands recebe o inventário por talhão (árvores/ha, altura média e dominante, diâmetro de copa, cobertura do dossel, classes de altura; com -spacing a grade de plantio e o estoque de cada talhão)</translation>
    </message>
    <message>
      <source>Stand id field</source>
      <translation>Campo do código do talhão</translation>
    </message>
    <message>
      <source>The stands' id field (default: the first of stand_id, talhao, id_talhao, cod_talhao, codigo, id, name, nome present; else 1, 2, ...)</source>
      <translation>O campo de código dos talhões (padrão: o primeiro presente entre stand_id, talhao, id_talhao, cod_talhao, codigo, id, name, nome; senão 1, 2, ...)</translation>
    </message>
    <message>
      <source>Per-stand inventory CSV</source>
      <translation>CSV do inventário por talhão</translation>
    </message>
    <message>
      <source>Also write the per-stand inventory as a table (.csv, or .xlsx), the stands' own attributes included</source>
      <translation>Gravar também o inventário por talhão como tabela (.csv ou .xlsx), com os atributos próprios dos talhões</translation>
    </message>
    <message>
      <source>Append to an existing GeoPackage</source>
      <translation>Acrescentar a um GeoPackage existente</translation>
    </message>
    <message>
      <source>Castro (2006) Table 1: ten smoothing/segmentation configurations compared</source>
      <translation>Castro (2006) Tabela 1: dez configurações de suavização/segmentação comparadas</translation>
    </message>
    <message>
      <source>Output CSV</source>
      <translation>CSV de saída</translation>
    </message>
    <message>
      <source>CHM cell size, m (Castro 2006: 0.2 m, the laser footprint), or auto = max(sqrt(1/n), 0.25) from the point density n</source>
      <translation>Tamanho da célula do CHM, m (Castro 2006: 0,2 m, a pegada do laser), ou auto = max(sqrt(1/n), 0,25) a partir da densidade de pontos n</translation>
    </message>
    <message>
      <source>Region-growing threshold step</source>
      <translation>Passo do limiar do crescimento de regiões</translation>
    </message>
    <message>
      <source>Tree tops: strict = strictly higher than all 8 neighbours, a flat top or a cell on the grid's border (which lacks neighbours) giving none (Castro's rule); lm = one top per plateau of 8-neighbour maxima (then region growing starts from the watershed's basins)</source>
      <translation>Topos das árvores: strict = estritamente mais alto que os 8 vizinhos, um topo plano ou uma célula na borda da grade (à qual faltam vizinhos) não dando nenhum (a regra de Castro); lm = um topo por platô de máximos em 8 vizinhos (o crescimento de regiões parte então das bacias do watershed)</translation>
    </message>
    <message>
      <source>DTM for points input (see chm); auto = class-2 ground points if any, else lowest:5 (Castro's DTM holds only ground points; -dtm min, the lowest point per cell, is the canopy where a cell holds one return)</source>
      <translation>MDT para entrada de pontos (ver chm); auto = pontos de solo de classe 2 se houver, senão lowest:5 (o MDT de Castro só contém pontos de solo; -dtm min, o ponto mais baixo por célula, é o dossel onde uma célula tem um único retorno)</translation>
    </message>
    <message>
      <source>CHM from points: pitfree = pit-free CHM of the first returns (Khosravipour et al. 2014); max = highest point per cell, gaps filled (Castro 2006); tin = one TIN of the first returns (here default max, Castro's surface)</source>
      <translation>CHM a partir dos pontos: pitfree = CHM sem buracos dos primeiros retornos (Khosravipour et al. 2014); max = ponto mais alto por célula, vazios preenchidos (Castro 2006); tin = um TIN dos primeiros retornos (aqui o padrão é max, a superfície de Castro)</translation>
    </message>
    <message>
      <source>Ground</source>
      <translation>Solo</translation>
    </message>
    <message>
      <source>Ground points by Kraus &amp; Pfeifer hierarchical robust interpolation (Leite et al.) and TIN densification, classified LAS/LAZ and DTM</source>
      <translation>Pontos de solo pela interpolação robusta hierárquica de Kraus &amp; Pfeifer (Leite et al.) e adensamento por TIN, LAS/LAZ classificado e MDT</translation>
    </message>
    <message>
      <source>Point file: LAS/LAZ or XYZ text (tab/space/comma/semicolon, decimal comma or point, optional header, may be gzip-compressed); or a folder, glob or .vpc of point files (each file classified with a buffer of its neighbours' points)</source>
      <translation>Arquivo de pontos: LAS/LAZ ou texto XYZ (tabulação/espaço/vírgula/ponto e vírgula, vírgula ou ponto decimal, cabeçalho opcional, pode estar comprimido em gzip); ou uma pasta, um padrão glob ou um .vpc de arquivos de pontos (cada arquivo classificado com uma borda dos pontos dos vizinhos)</translation>
    </message>
    <message>
      <source>Output classified LAS/LAZ (ground = class 2); for several input files, a folder that gets one classified file per input, same name</source>
      <translation>LAS/LAZ classificado de saída (solo = classe 2); para vários arquivos de entrada, uma pasta que recebe um arquivo classificado por entrada, com o mesmo nome</translation>
    </message>
    <message>
      <source>Also write the DTM GeoTIFF (linear TIN of the ground points; one seamless mosaic over every input file)</source>
      <translation>Gravar também o GeoTIFF do MDT (TIN linear dos pontos de solo; um mosaico contínuo sobre todos os arquivos de entrada)</translation>
    </message>
    <message>
      <source>DTM cell size, m, or auto = sqrt(1/n) (Leite et al.)</source>
      <translation>Tamanho da célula do MDT, m, ou auto = sqrt(1/n) (Leite et al.)</translation>
    </message>
    <message>
      <source>Kraus &amp; Pfeifer g: residuals at or below g get weight 1</source>
      <translation>g de Kraus &amp; Pfeifer: resíduos menores ou iguais a g recebem peso 1</translation>
    </message>
    <message>
      <source>Kraus &amp; Pfeifer w: residuals above g + w get weight 0</source>
      <translation>w de Kraus &amp; Pfeifer: resíduos acima de g + w recebem peso 0</translation>
    </message>
    <message>
      <source>Weight function a</source>
      <translation>Função de peso a</translation>
    </message>
    <message>
      <source>Weight function b</source>
      <translation>Função de peso b</translation>
    </message>
    <message>
      <source>Iterations per level</source>
      <translation>Iterações por nível</translation>
    </message>
    <message>
      <source>Cell of the finest filter surface</source>
      <translation>Célula da superfície mais fina do filtro</translation>
    </message>
    <message>
      <source>Filter levels</source>
      <translation>Níveis do filtro</translation>
    </message>
    <message>
      <source>Hierarchy levels (cell x 2^(levels-1) down to cell); 1 = plain filter</source>
      <translation>Níveis da hierarquia (célula x 2^(níveis-1) até a célula); 1 = filtro simples</translation>
    </message>
    <message>
      <source>w growth per level</source>
      <translation>Crescimento de w por nível</translation>
    </message>
    <message>
      <source>At coarser levels w grows by this much per metre of cell (w + k (c - cell)) so coarse surfaces keep hilltops and crests</source>
      <translation>Nos níveis mais grossos w cresce este tanto por metro de célula (w + k (c - célula)), para que as superfícies grossas mantenham topos de morro e cristas</translation>
    </message>
    <message>
      <source>Densification passes</source>
      <translation>Passagens de adensamento</translation>
    </message>
    <message>
      <source>Densification passes against the TIN of the ground points (stops when nothing changes); 0 = the plain robust-interpolation result</source>
      <translation>Passagens de adensamento contra o TIN dos pontos de solo (para quando nada muda); 0 = o resultado da interpolação robusta simples</translation>
    </message>
    <message>
      <source>Tolerance above the surface</source>
      <translation>Tolerância acima da superfície</translation>
    </message>
    <message>
      <source>Tolerance above the surface (FUSION /tolerance): when refining, a point is ground when -(1 + slope S) &lt;= residual &lt;= tolerance + slope S (S the TIN's slope; default 0.3 m); without refining, ground = residual &lt;= tolerance when given, else residual &lt;= g + w</source>
      <translation>Tolerância acima da superfície (/tolerance do FUSION): no refinamento, um ponto é solo quando -(1 + declividade S) &lt;= resíduo &lt;= tolerância + declividade S (S a declividade do TIN; padrão 0,3 m); sem refinamento, solo = resíduo &lt;= tolerância quando informada, senão resíduo &lt;= g + w</translation>
    </message>
    <message>
      <source>Slope tolerance factor</source>
      <translation>Fator de tolerância da declividade</translation>
    </message>
    <message>
      <source>Tolerance added per unit of terrain slope (m/m) when refining</source>
      <translation>Tolerância somada por unidade de declividade do terreno (m/m) no refinamento</translation>
    </message>
    <message>
      <source>TIN vertex cell</source>
      <translation>Célula dos vértices do TIN</translation>
    </message>
    <message>
      <source>When refining, the TIN is built from the lowest ground point per cell of this size (keeps it out of shrubs); 0 = every ground point</source>
      <translation>No refinamento, o TIN é construído com o ponto de solo mais baixo por célula deste tamanho (o que o mantém fora dos arbustos); 0 = todos os pontos de solo</translation>
    </message>
    <message>
      <source>Low-point depth</source>
      <translation>Profundidade dos pontos baixos</translation>
    </message>
    <message>
      <source>Leave out of the surfaces points this far below the second lowest of their 10 nearest neighbours (multipath); 0 = off</source>
      <translation>Exclui das superfícies os pontos a esta distância abaixo do segundo mais baixo dos seus 10 vizinhos mais próximos (multicaminho); 0 = desligado</translation>
    </message>
    <message>
      <source>Shift g automatically</source>
      <translation>Deslocar g automaticamente</translation>
    </message>
    <message>
      <source>Shift g automatically each iteration from the residual histogram (Kraus &amp; Pfeifer)</source>
      <translation>Desloca g automaticamente a cada iteração pelo histograma dos resíduos (Kraus &amp; Pfeifer)</translation>
    </message>
    <message>
      <source>Reclassify other classes too</source>
      <translation>Reclassificar também as outras classes</translation>
    </message>
    <message>
      <source>Also give the filter's decision to points of other classes (water, buildings...); by default only classes 0, 1, 2 change</source>
      <translation>Aplica também a decisão do filtro aos pontos de outras classes (água, edificações...); por padrão só as classes 0, 1, 2 mudam</translation>
    </message>
    <message>
      <source>Buffer of neighbouring files' points around each file (default 30 m)</source>
      <translation>Borda de pontos dos arquivos vizinhos em torno de cada arquivo (padrão 30 m)</translation>
    </message>
    <message>
      <source>DTM quality sweep (Leite et al.): Kraus &amp; Pfeifer (g, w) grid, GLCM texture, PCA, k-means</source>
      <translation>Varredura da qualidade do MDT (Leite et al.): grade (g, w) de Kraus &amp; Pfeifer, textura GLCM, ACP, k-médias</translation>
    </message>
    <message>
      <source>Point file: LAS/LAZ or XYZ text (tab/space/comma/semicolon, decimal comma or point, optional header, may be gzip-compressed); or a folder, glob or .vpc of point files (each file filtered with a buffer of its neighbours' points, one DTM over all)</source>
      <translation>Arquivo de pontos: LAS/LAZ ou texto XYZ (tabulação/espaço/vírgula/ponto e vírgula, vírgula ou ponto decimal, cabeçalho opcional, pode estar comprimido em gzip); ou uma pasta, um padrão glob ou um .vpc de arquivos de pontos (cada arquivo filtrado com uma borda dos pontos dos vizinhos, um MDT sobre todos)</translation>
    </message>
    <message>
      <source>Output folder</source>
      <translation>Pasta de saída</translation>
    </message>
    <message>
      <source>Output folder (CSV, hillshade PNGs, recommended_dtm.tif). The CSV ranks the DTMs (1 = most trusted) with a role and why: good (smooth texture, agreeing with the sweep's median DTM), noisy, outlier (smooth but far from that median), incomplete (under 1 ground point per 10 m², or not covering the data)</source>
      <translation>Pasta de saída (CSV, PNGs de relevo sombreado, recommended_dtm.tif). O CSV ordena os MDTs (1 = o mais confiável) com um papel e o porquê: good (textura lisa, de acordo com o MDT mediano da varredura), noisy (ruidoso), outlier (liso mas longe dessa mediana), incomplete (menos de 1 ponto de solo por 10 m², ou sem cobrir os dados)</translation>
    </message>
    <message>
      <source>g values START:STOP:STEP</source>
      <translation>Valores de g INÍCIO:FIM:PASSO</translation>
    </message>
    <message>
      <source>g values START:STOP:STEP (Leite et al.: -4:1:0.5)</source>
      <translation>Valores de g INÍCIO:FIM:PASSO (Leite et al.: -4:1:0.5)</translation>
    </message>
    <message>
      <source>w values START:STOP:STEP</source>
      <translation>Valores de w INÍCIO:FIM:PASSO</translation>
    </message>
    <message>
      <source>w values START:STOP:STEP (Leite et al.: 1:4:0.5)</source>
      <translation>Valores de w INÍCIO:FIM:PASSO (Leite et al.: 1:4:0.5)</translation>
    </message>
    <message>
      <source>Reference ground (DTM GeoTIFF; auto = class-2 points; none)</source>
      <translation>Solo de referência (GeoTIFF de MDT; auto = pontos de classe 2; none)</translation>
    </message>
    <message>
      <source>Reference ground to check each DTM against: a DTM GeoTIFF, auto = the file's class-2 points (the vendor's ground) when it has any, or none. With a reference, the recommended DTM is the complete one closest to it (the texture's choice is reported beside)</source>
      <translation>Solo de referência contra o qual cada MDT é verificado: um GeoTIFF de MDT, auto = os pontos de classe 2 do arquivo (o solo do fornecedor) quando houver, ou none. Com uma referência, o MDT recomendado é o completo mais próximo dela (a escolha pela textura é informada ao lado)</translation>
    </message>
    <message>
      <source>Densification passes after the robust interpolation; 0 (Leite et al.'s filter) makes the DTM depend on g and w, with passes most (g, w) give one DTM</source>
      <translation>Passagens de adensamento após a interpolação robusta; 0 (o filtro de Leite et al.) faz o MDT depender de g e w; com passagens, a maioria dos (g, w) dá um mesmo MDT</translation>
    </message>
    <message>
      <source>k-means random seed</source>
      <translation>Semente aleatória do k-médias</translation>
    </message>
    <message>
      <source>Terrestrial</source>
      <translation>Terrestre</translation>
    </message>
    <message>
      <source>Trunk points, DBH and taper of one tree by the Dmax filter (Buck et al. 2014)</source>
      <translation>Pontos do tronco, DAP e afilamento de uma árvore pelo filtro Dmax (Buck et al. 2014)</translation>
    </message>
    <message>
      <source>One tree's TLS points (LAS/LAZ or XYZ)</source>
      <translation>Pontos TLS de uma árvore (LAS/LAZ ou XYZ)</translation>
    </message>
    <message>
      <source>Output prefix</source>
      <translation>Prefixo de saída</translation>
    </message>
    <message>
      <source>Output prefix: PREFIX_trunk.laz, _sections.csv/.gpkg, _summary.json, _taper.png</source>
      <translation>Prefixo de saída: PREFIXO_trunk.laz, _sections.csv/.gpkg, _summary.json, _taper.png</translation>
    </message>
    <message>
      <source>Section thickness</source>
      <translation>Espessura da seção</translation>
    </message>
    <message>
      <source>Half-size of the square search region around the stem</source>
      <translation>Meio lado da região quadrada de busca em torno do tronco</translation>
    </message>
    <message>
      <source>Horizontal search spacing</source>
      <translation>Espaçamento horizontal da busca</translation>
    </message>
    <message>
      <source>Horizontal point spacing of the scan (sets the search-point step)</source>
      <translation>Espaçamento horizontal entre pontos da varredura (define o passo dos pontos de busca)</translation>
    </message>
    <message>
      <source>Vertical scan spacing</source>
      <translation>Espaçamento vertical da varredura</translation>
    </message>
    <message>
      <source>Vertical point spacing of the scan: a complete section holds 2 pi r / hspacing x section / vspacing points (expected_points, completeness in the sections CSV); -section must be at least this</source>
      <translation>Espaçamento vertical entre pontos da varredura: uma seção completa contém 2 pi r / hspacing x section / vspacing pontos (expected_points, completeness no CSV das seções); -section precisa ser pelo menos este valor</translation>
    </message>
    <message>
      <source>Base height</source>
      <translation>Altura da base</translation>
    </message>
    <message>
      <source>Base height: auto (local ground) or a z value</source>
      <translation>Altura da base: auto (solo local) ou um valor de z</translation>
    </message>
    <message>
      <source>First section this far above the base</source>
      <translation>Primeira seção a esta altura acima da base</translation>
    </message>
    <message>
      <source>Roots / stem / canopy from the point-density profile (Queiroz 2017)</source>
      <translation>Raízes / tronco / copa pelo perfil de densidade de pontos (Queiroz 2017)</translation>
    </message>
    <message>
      <source>Output LAS/LAZ with the extra dimension part (1 roots, 2 stem, 3 canopy); boundaries JSON/CSV and a PNG beside it</source>
      <translation>LAS/LAZ de saída com a dimensão extra part (1 raízes, 2 tronco, 3 copa); limites em JSON/CSV e um PNG ao lado</translation>
    </message>
    <message>
      <source>Slice height</source>
      <translation>Altura da fatia</translation>
    </message>
    <message>
      <source>Gaussian smoothing sigma</source>
      <translation>Sigma da suavização gaussiana</translation>
    </message>
    <message>
      <source>Gaussian smoothing sigma (0.1, 0.3, 0.6 tested; 0.3 best)</source>
      <translation>Sigma da suavização gaussiana (0,1, 0,3, 0,6 testados; 0,3 o melhor)</translation>
    </message>
    <message>
      <source>Boundary rule</source>
      <translation>Regra dos limites</translation>
    </message>
    <message>
      <source>Boundaries: spread = stem start at the density profile's first concave-to-convex inflection, canopy start where the horizontal spread leaves the stem's (3x and 0.25 m more, over a metre); queiroz = Queiroz's ordinal rule, the 1st, 2nd and 3rd inflections are tree, stem and canopy start</source>
      <translation>Limites: spread = início do tronco na primeira inflexão côncava-convexa do perfil de densidade, início da copa onde o espalhamento horizontal deixa o do tronco (3x e 0,25 m a mais, ao longo de um metro); queiroz = a regra ordinal de Queiroz, a 1ª, 2ª e 3ª inflexões são o início da árvore, do tronco e da copa</translation>
    </message>
    <message>
      <source>Accuracy of tree tops against reference trees (Eysn et al. 2015 matching): recall, precision, F, height bias and RMSE</source>
      <translation>Exatidão dos topos das árvores contra árvores de referência (associação de Eysn et al. 2015): revocação, precisão, F, viés e REQM da altura</translation>
    </message>
    <message>
      <source>Detected tree tops</source>
      <translation>Topos de árvores detectados</translation>
    </message>
    <message>
      <source>Detected trees: a GeoPackage from trees (layer tree_tops) or a CSV with x, y, height</source>
      <translation>Árvores detectadas: um GeoPackage do trees (camada tree_tops) ou um CSV com x, y, altura</translation>
    </message>
    <message>
      <source>Reference trees</source>
      <translation>Árvores de referência</translation>
    </message>
    <message>
      <source>Reference trees: CSV with x, y and optionally height, or a vector file of points</source>
      <translation>Árvores de referência: CSV com x, y e opcionalmente a altura, ou um arquivo vetorial de pontos</translation>
    </message>
    <message>
      <source>Also write the report</source>
      <translation>Gravar também o relatório</translation>
    </message>
    <message>
      <source>Also write the report (.json) or the matched pairs (.csv)</source>
      <translation>Gravar também o relatório (.json) ou os pares associados (.csv)</translation>
    </message>
    <message>
      <source>Largest horizontal distance of a match</source>
      <translation>Maior distância horizontal de uma associação</translation>
    </message>
    <message>
      <source>Largest height difference of a match</source>
      <translation>Maior diferença de altura de uma associação</translation>
    </message>
    <message>
      <source>Layer of the detected file</source>
      <translation>Camada do arquivo detectado</translation>
    </message>
    <message>
      <source>Layer of the detected file (default: the tree_tops layer)</source>
      <translation>Camada do arquivo detectado (padrão: a camada tree_tops)</translation>
    </message>
    <message>
      <source>Layer of the reference file</source>
      <translation>Camada do arquivo de referência</translation>
    </message>
    <message>
      <source>Layer of the reference file (default: the first)</source>
      <translation>Camada do arquivo de referência (padrão: a primeira)</translation>
    </message>
    <message>
      <source>Reference area (xmin,ymin,xmax,ymax or polygons)</source>
      <translation>Área de referência (xmin,ymin,xmax,ymax ou polígonos)</translation>
    </message>
    <message>
      <source>Where the reference was measured: xmin,ymin,xmax,ymax or a polygon file (PATH or PATH:LAYER); detections outside it are not false positives, references outside it are left out</source>
      <translation>Onde a referência foi medida: xmin,ymin,xmax,ymax ou um arquivo de polígonos (CAMINHO ou CAMINHO:CAMADA); detecções fora dela não são falsos positivos, referências fora dela ficam de fora</translation>
    </message>
    <message>
      <source>CSV table option KEY=VALUE: SEPARATOR=COMMA|SEMICOLON|TAB|SPACE, DECIMAL=POINT|COMMA, WRITE_BOM=YES|NO (default: the locale's; pt_BR: semicolon, decimal comma, BOM); a table named .xlsx is a workbook</source>
      <translation>Opção de tabela CSV CHAVE=VALOR: SEPARATOR=COMMA|SEMICOLON|TAB|SPACE, DECIMAL=POINT|COMMA, WRITE_BOM=YES|NO (padrão: o do idioma do sistema; pt_BR: ponto e vírgula, vírgula decimal, BOM); uma tabela com nome .xlsx é uma planilha</translation>
    </message>
    <message>
      <source>Inventory</source>
      <translation>Inventário</translation>
    </message>
    <message>
      <source>Standard height metrics (lidR .stdmetrics_z, FUSION L-moments and cover) per cell (multi-band GeoTIFF) or per field plot and stand (GeoPackage)</source>
      <translation>Métricas de altura padrão (lidR .stdmetrics_z, L-momentos e cobertura do FUSION) por célula (GeoTIFF de várias bandas) ou por parcela e talhão (GeoPackage)</translation>
    </message>
    <message>
      <source>Output: a .tif gets one named band a metric per cell; a .gpkg the layers plot_metrics and stand_metrics</source>
      <translation>Saída: um .tif recebe uma banda nomeada por métrica em cada célula; um .gpkg as camadas plot_metrics e stand_metrics</translation>
    </message>
    <message>
      <source>Metric cell size (use the plots' size for an area-based model: 20 m for 400 m² plots)</source>
      <translation>Tamanho da célula das métricas (use o tamanho das parcelas para um modelo de área: 20 m para parcelas de 400 m²)</translation>
    </message>
    <message>
      <source>Plots</source>
      <translation>Parcelas</translation>
    </message>
    <message>
      <source>Field plots (parcelas): a polygon layer, or plot centres (points) with -plot_radius, PATH or PATH:LAYER</source>
      <translation>Parcelas de campo: uma camada de polígonos, ou os centros das parcelas (pontos) com -plot_radius, CAMINHO ou CAMINHO:CAMADA</translation>
    </message>
    <message>
      <source>Plot id field</source>
      <translation>Campo de id da parcela</translation>
    </message>
    <message>
      <source>The plots' id field (default: the first of plot_id, parcela, id_parcela, plot, id, name present; else 1, 2, ...)</source>
      <translation>O campo de id das parcelas (padrão: o primeiro presente entre plot_id, parcela, id_parcela, plot, id, name; senão 1, 2, ...)</translation>
    </message>
    <message>
      <source>Plot radius</source>
      <translation>Raio da parcela</translation>
    </message>
    <message>
      <source>Radius of circular plots given by their centres (11.28 m for 400 m²)</source>
      <translation>Raio das parcelas circulares dadas pelos centros (11,28 m para 400 m²)</translation>
    </message>
    <message>
      <source>Stand (talhão) polygons, PATH or PATH:LAYER</source>
      <translation>Polígonos dos talhões, CAMINHO ou CAMINHO:CAMADA</translation>
    </message>
    <message>
      <source>The stands' id field (default: stand_id, talhao, ... or numbered)</source>
      <translation>O campo de id dos talhões (padrão: stand_id, talhao, ... ou numerados)</translation>
    </message>
    <message>
      <source>Min height</source>
      <translation>Altura mínima</translation>
    </message>
    <message>
      <source>Metrics of the returns above this height (m); none = of every return (lidR's pixel_metrics default); cover counts the first returns above it</source>
      <translation>Métricas dos retornos acima desta altura (m); none = de todos os retornos (o padrão do pixel_metrics do lidR); a cobertura conta os primeiros retornos acima dela</translation>
    </message>
    <message>
      <source>Metrics of all returns or of the first returns</source>
      <translation>Métricas de todos os retornos ou dos primeiros retornos</translation>
    </message>
    <message>
      <source>Ground for the heights (see chm); none = heights already normalised</source>
      <translation>Terreno para as alturas (veja chm); none = alturas já normalizadas</translation>
    </message>
    <message>
      <source>Wood volume per stand (m³/ha, m³, basal area) with 95 % intervals, from LiDAR and field plots: area-based model and/or detected trees</source>
      <translation>Volume de madeira por talhão (m³/ha, m³, área basal) com intervalos de 95 %, a partir do LiDAR e das parcelas de campo: modelo de área e/ou árvores detectadas</translation>
    </message>
    <message>
      <source>Field plots (parcelas): a polygon layer, or plot centres (points) with -plot_radius; may carry volume_m3_ha when there is no tree table</source>
      <translation>Parcelas de campo: uma camada de polígonos, ou os centros das parcelas (pontos) com -plot_radius; pode trazer volume_m3_ha quando não há tabela de árvores</translation>
    </message>
    <message>
      <source>Output GeoPackage (layers plots, stands, tree_tops); OUT_volume.tif (m³/ha), OUT_report.json and OUT_report.png beside it</source>
      <translation>GeoPackage de saída (camadas plots, stands, tree_tops); OUT_volume.tif (m³/ha), OUT_report.json e OUT_report.png ao lado</translation>
    </message>
    <message>
      <source>Field trees table</source>
      <translation>Tabela das árvores de campo</translation>
    </message>
    <message>
      <source>Field trees table (CSV/TXT, pt-BR or English): plot (parcela), tree (arvore), DAP cm (dap) or CAP cm (cap), HT m (ht, for all or some trees), volume m³ (optional); .xlsx read too</source>
      <translation>Tabela das árvores de campo (CSV/TXT, pt-BR ou inglês): parcela, arvore, DAP cm (dap) ou CAP cm (cap), HT m (ht, de todas ou de algumas árvores), volume m³ (opcional); lê também .xlsx</translation>
    </message>
    <message>
      <source>Volume field</source>
      <translation>Campo de volume</translation>
    </message>
    <message>
      <source>The plots' volume field (m³/ha) when there is no tree table (default: the first of volume_m3_ha, vol_ha, vtcc_ha, volume, vol)</source>
      <translation>Campo de volume das parcelas (m³/ha) quando não há tabela de árvores (padrão: o primeiro de volume_m3_ha, vol_ha, vtcc_ha, volume, vol)</translation>
    </message>
    <message>
      <source>Volume equation</source>
      <translation>Equação de volume</translation>
    </message>
    <message>
      <source>Schumacher-Hall coefficients b0,b1,b2 of V = b0·DAP^b1·HT^b2 (DAP cm, HT m, V m³), or ff:F for a form factor F (V = F·g·HT, g = π·DAP²/40000); default: fitted on the trees that carry a volume</source>
      <translation>Coeficientes b0,b1,b2 de Schumacher-Hall de V = b0·DAP^b1·HT^b2 (DAP cm, HT m, V m³), ou ff:F para um fator de forma F (V = F·g·HT, g = π·DAP²/40000); padrão: ajustados nas árvores que trazem volume</translation>
    </message>
    <message>
      <source>Approach</source>
      <translation>Abordagem</translation>
    </message>
    <message>
      <source>aba = area-based model of the plots' height metrics; trees = detected trees' volume from their heights, scaled by the plots; both</source>
      <translation>aba = modelo de área com as métricas de altura das parcelas; trees = volume das árvores detectadas a partir das alturas, ajustado pelas parcelas; both = ambos</translation>
    </message>
    <message>
      <source>Cell size of the wall-to-wall metrics: auto = the plots' size (20 m for 400 m² plots)</source>
      <translation>Tamanho da célula das métricas em toda a área: auto = o tamanho das parcelas (20 m para parcelas de 400 m²)</translation>
    </message>
    <message>
      <source>Bootstrap resamples of the plots for the intervals</source>
      <translation>Reamostragens bootstrap das parcelas para os intervalos</translation>
    </message>
    <message>
      <source>Estimator</source>
      <translation>Estimador</translation>
    </message>
    <message>
      <source>A stand's figure: eblup = the model's, corrected by the stand's own plots as far as they can be trusted; model = the model's alone</source>
      <translation>O valor do talhão: eblup = o do modelo, corrigido pelas parcelas do próprio talhão na medida em que merecem confiança; model = só o do modelo</translation>
    </message>
    <message>
      <source>Also write the per-stand figures as a table (.csv, or .xlsx), the stands' own attributes included</source>
      <translation>Gravar também os valores por talhão como tabela (.csv ou .xlsx), com os atributos próprios dos talhões</translation>
    </message>
    <message>
      <source>GeoPackage layer creation option KEY=VALUE; and for the -stand_csv table CSV table option KEY=VALUE: SEPARATOR=COMMA|SEMICOLON|TAB|SPACE, DECIMAL=POINT|COMMA, WRITE_BOM=YES|NO (default: the locale's; pt_BR: semicolon, decimal comma, BOM); a table named .xlsx is a workbook</source>
      <translation>Opção de criação de camada do GeoPackage CHAVE=VALOR; e, para a tabela -stand_csv, opção de tabela CSV CHAVE=VALOR: SEPARATOR=COMMA|SEMICOLON|TAB|SPACE, DECIMAL=POINT|COMMA, WRITE_BOM=YES|NO (padrão: o do idioma do sistema; pt_BR: ponto e vírgula, vírgula decimal, BOM); uma tabela com nome .xlsx é uma planilha</translation>
    </message>
    <message>
      <source>Volume raster (m³/ha)</source>
      <translation>Raster de volume (m³/ha)</translation>
    </message>
    <message>
      <source>Model report (JSON)</source>
      <translation>Relatório do modelo (JSON)</translation>
    </message>
    <message>
      <source>Measured against predicted (PNG)</source>
      <translation>Medido contra estimado (PNG)</translation>
    </message>
    <message>
      <source>Demo</source>
      <translation>Demonstração</translation>
    </message>
    <message>
      <source>Generate a synthetic eucalyptus stand with known trees and process it</source>
      <translation>Gera um talhão sintético de eucalipto com árvores conhecidas e o processa</translation>
    </message>
    <message>
      <source>Output folder (default lidartrees_demo)</source>
      <translation>Pasta de saída (padrão lidartrees_demo)</translation>
    </message>
    <message>
      <source>{castro}, §2.3: DSM = highest point per cell, DTM = lowest, gap filling by the mean of the 8 neighbours (-chm max). {khosravipour} (-chm pitfree, the default). Leite et al.: C = sqrt(1/n).</source>
      <translation>{castro}, §2.3: MDS = ponto mais alto por célula, MDT = o mais baixo, vazios preenchidos pela média dos 8 vizinhos (-chm max). {khosravipour} (-chm pitfree, o padrão). Leite et al.: C = sqrt(1/n).</translation>
    </message>
    <message>
      <source>{castro}, §2.3.</source>
      <translation>{castro}, §2.3.</translation>
    </message>
    <message>
      <source>{castro}: Gaussian masks, grey morphology (abefec...), region growing after Hyyppä et al. (2001) (Annex 2), Vincent &amp; Soille (1991) watershed (Annex 1). Pantaleão, Dutra &amp; Macedo, TreeX: moving window + priority growing. {khosravipour}. Eysn, L. et al. (2015), Forests 6, 1721-1747 (evaluation).</source>
      <translation>{castro}: máscaras gaussianas, morfologia em tons de cinza (abefec...), crescimento de regiões segundo Hyyppä et al. (2001) (Anexo 2), watershed de Vincent &amp; Soille (1991) (Anexo 1). Pantaleão, Dutra &amp; Macedo, TreeX: janela móvel + crescimento por prioridade. {khosravipour}. Eysn, L. et al. (2015), Forests 6, 1721-1747 (avaliação).</translation>
    </message>
    <message>
      <source>{castro}, Table 1.</source>
      <translation>{castro}, Tabela 1.</translation>
    </message>
    <message>
      <source>Eysn, L. et al. (2015). A benchmark of lidar-based single tree detection methods using heterogeneous forest data from the Alpine Space. Forests 6, 1721-1747.</source>
      <translation>Eysn, L. et al. (2015). A benchmark of lidar-based single tree detection methods using heterogeneous forest data from the Alpine Space. Forests 6, 1721-1747.</translation>
    </message>
    <message>
      <source>Kraus, K. &amp; Pfeifer, N. (1998) robust interpolation, as in FUSION's GroundFilter, hierarchical after Pfeifer, N. et al. (2001), then densification against a TIN of the ground; (g, w) for eucalyptus by Leite et al..</source>
      <translation>Kraus, K. &amp; Pfeifer, N. (1998), interpolação robusta, como no GroundFilter do FUSION, hierárquica segundo Pfeifer, N. et al. (2001), seguida de adensamento contra um TIN do solo; (g, w) para eucalipto por Leite et al.</translation>
    </message>
    <message>
      <source>Leite et al.: 77 (g, w) DTMs judged by GLCM texture, PCA and k-means.</source>
      <translation>Leite et al.: 77 MDTs (g, w) avaliados por textura GLCM, ACP e k-médias.</translation>
    </message>
    <message>
      <source>Buck, A. L. B. et al. (2014), Dmax filter for trunk points of Pinus in TLS clouds.</source>
      <translation>Buck, A. L. B. et al. (2014), filtro Dmax para os pontos do tronco de Pinus em nuvens TLS.</translation>
    </message>
    <message>
      <source>Queiroz (2017), vertical segmentation of mangrove trees into roots, stem and canopy from the point-density profile.</source>
      <translation>Queiroz (2017), segmentação vertical de árvores de mangue em raízes, tronco e copa pelo perfil de densidade de pontos.</translation>
    </message>
    <message>
      <source>lidR's stdmetrics_z (Roussel, J.-R. et al. (2020), lidR, Remote Sensing of Environment 251, 112061); FUSION's L-moments and cover (McGaughey, R. J., FUSION/LDV manual). Definitions: docs/VOLUME.md.</source>
      <translation>stdmetrics_z do lidR (Roussel, J.-R. et al. (2020), lidR, Remote Sensing of Environment 251, 112061); L-momentos e cobertura do FUSION (McGaughey, R. J., manual do FUSION/LDV). Definições: docs/VOLUME.md.</translation>
    </message>
    <message>
      <source>Area-based approach (Næsset, E. (2002), Remote Sensing of Environment 80, 88-99); Schumacher, F. X. &amp; Hall, F. S. (1933) volume equation; eucalyptus plantations: Silva, C. A. et al. (2016), Forestry. Model form, intervals and limits: docs/VOLUME.md.</source>
      <translation>Abordagem de área (Næsset, E. (2002), Remote Sensing of Environment 80, 88-99); equação de volume de Schumacher, F. X. &amp; Hall, F. S. (1933); plantios de eucalipto: Silva, C. A. et al. (2016), Forestry. Forma do modelo, intervalos e limites: docs/VOLUME.md.</translation>
    </message>
    <message>
      <source>Plantation mode: planting spacing ROWSxTREES in m, e.g. 3x2, or auto (found under the tops, per stand with -stands); each empty planting position classified missing, suppressed or uncertain (gaps layer), and stocking, added to the output. Default: auto with -stands (a stand that shows no lattice keeps the defaults' trees), none without</source>
      <translation type="vanished">Modo plantio: espaçamento de plantio LINHASxPLANTAS em m, p. ex. 3x2, ou auto (encontrado sob os topos, por talhão com -stands); cada cova vazia classificada como falha, dominada ou incerta (camada gaps), e o estoque, acrescentados à saída. Padrão: auto com -stands (um talhão que não mostra grade de plantio fica com as árvores do padrão); sem -stands, nenhum</translation>
    </message>
    <message>
      <source>Plantation mode: planting spacing ROWSxTREES in m, e.g. 3x2, or auto (found under the tops, per stand with -stands); each empty planting position classified missing, suppressed or uncertain (gaps layer), and stocking, added to the output</source>
      <translation type="vanished">Modo plantio: espaçamento de plantio LINHASxPLANTAS em m, p. ex. 3x2, ou auto (encontrado sob os topos, por talhão com -stands); cada cova vazia classificada como falha, dominada ou incerta (camada gaps), e o estoque, acrescentados à saída</translation>
    </message>
    <message>
      <source>Without -spacing: auto = when the tops lie on a planting lattice (at least 100 trees, lattice fit &gt;= 0.25), look again at its empty positions for trees the tops finder missed (each tile with its buffer); none = off. Default: auto with the default method (rg, -smooth auto, -tops auto), none with a seed method or configuration, which then runs as its paper defines it</source>
      <translation type="vanished">Sem -spacing: auto = quando os topos estão sobre uma grade de plantio (pelo menos 100 árvores, ajuste da grade &gt;= 0,25), procura de novo nas covas vazias as árvores que o localizador de topos perdeu (cada bloco com a sua borda); none = desligado. Padrão: auto com o método padrão (rg, -smooth auto, -tops auto), none com um método ou configuração dos artigos de origem, que então roda como o seu artigo o define</translation>
    </message>
    <message>
      <source>Schumacher-Hall coefficients b0,b1,b2 of V = b0·DAP^b1·HT^b2 (DAP cm, HT m, V m³); default: fitted on the trees that carry a volume</source>
      <translation type="vanished">Coeficientes b0,b1,b2 de Schumacher-Hall de V = b0·DAP^b1·HT^b2 (DAP cm, HT m, V m³); padrão: ajustados nas árvores que trazem volume</translation>
    </message>
    <message>
      <source>Plot id</source>
      <translation type="vanished">Id da parcela</translation>
    </message>
    <message>
      <source>Trees table</source>
      <translation type="vanished">Tabela de árvores</translation>
    </message>
    <message>
      <source>Field trees table (CSV/TXT, pt-BR or English): plot (parcela), tree (arvore), DAP cm (dap) or CAP cm (cap), HT m (ht, for all or some trees), volume m³ (optional)</source>
      <translation type="vanished">Tabela das árvores de campo (CSV/TXT, pt-BR ou inglês): parcela, arvore, DAP cm (dap) ou CAP cm (cap), HT m (ht, de todas ou de algumas árvores), volume m³ (opcional)</translation>
    </message>
    <message>
      <source>LiDAR Trees: the 'lidartrees' command was not found. Install the lidartrees_gis package in its own environment (python3 -m venv ~/.venvs/lidartrees &amp;&amp; ~/.venvs/lidartrees/bin/pip install /path/to/lidartrees_gis, the package's folder or wheel) and, if it is not on the PATH, set the environment variable LIDARTREES_EXE or the QGIS setting '{setting}' to its path.</source>
      <translation type="vanished">LiDAR Trees: o comando 'lidartrees' não foi encontrado. Instale o pacote lidartrees_gis em um ambiente próprio (python3 -m venv ~/.venvs/lidartrees &amp;&amp; ~/.venvs/lidartrees/bin/pip install /caminho/para/lidartrees_gis, a pasta ou o wheel do pacote) e, se ele não estiver no PATH, defina a variável de ambiente LIDARTREES_EXE ou a configuração do QGIS '{setting}' com o caminho dele.</translation>
    </message>
    <message>
      <source>CHM filter: auto = a Gaussian sized from the crown scale (measured on the CHM, or from -spacing); none; gauss3 (Castro's fine mask); gauss5 (coarse mask); gauss:SIGMA (m); or OP:ELEMENT[:SIZE], OP in erode, dilate, open, close, abefec, fecabe, fecabefec, abefecabe; ELEMENT cross, square, rhombus</source>
      <translation type="vanished">Filtro do CHM: auto = uma gaussiana dimensionada pela escala de copa (medida no CHM, ou a partir de -spacing); none; gauss3 (máscara fina de Castro); gauss5 (máscara grossa); gauss:SIGMA (m); ou OP:ELEMENTO[:TAMANHO], OP entre erode, dilate, open, close, abefec, fecabe, fecabefec, abefecabe; ELEMENTO cross, square, rhombus</translation>
    </message>
    <message>
      <source>GeoPackage layer creation option KEY=VALUE</source>
      <translation type="vanished">Opção de criação da camada GeoPackage CHAVE=VALOR</translation>
    </message>
    <message>
      <source>Trees CSV (TreeX layout)</source>
      <translation type="vanished">CSV das árvores (formato do TreeX)</translation>
    </message>
    <message>
      <source>Also write a CSV in TreeX's layout</source>
      <translation type="vanished">Gravar também um CSV no formato do TreeX</translation>
    </message>
    <message>
      <source>Also write the per-stand inventory as a CSV table</source>
      <translation type="vanished">Gravar também o inventário por talhão como tabela CSV</translation>
    </message>
    <message>
      <source>Output folder (CSV, hillshade PNGs, recommended_dtm.tif)</source>
      <translation type="vanished">Pasta de saída (CSV, PNGs de relevo sombreado, recommended_dtm.tif)</translation>
    </message>
  </context>
</TS>
